"""What a motion is: its kind, its phase, and the records the supervisor and its parts share.

Also the stop generation (:class:`Generation`), which every part reads to guard its commands, and
the plain facts about a guide pulse's axis and sense, which guiding, the offset ledger and the
offset payer all use (kept here so none of them imports another for them).
"""

from __future__ import annotations

import logging
import math
import threading
from collections.abc import Callable
from dataclasses import dataclass, field
from datetime import datetime
from enum import Enum

from ..clients import ClientKey
from ..sky import SIDEREAL_DEG_S
from ..zwo.wire_values import Direction

log = logging.getLogger(__name__)


#: The mount's status flags can lag a command by ~0.5 s (field notes §5.1).
STATUS_LAG_S = 1.0
MAX_MOTION_S = 600.0
#: Braking deceleration of the axes (deg/s²): the emulator's, and the AM5's observed order of size.
DECELERATION_DEG_S2 = 3.0
#: The fastest an axis turns (1440x sidereal). Readings can suggest more (a slew through the pole
#: turns the RA reading by 12 h at once), so speeds estimated from them are capped here.
MAX_AXIS_DEG_S = 1440 * SIDEREAL_DEG_S
#: Wall-clock period of the supervisor loop (real seconds).
TICK_S = 0.1


class MotionKind(Enum):
    GOTO = "slew"
    ALTAZ = "slew to alt/az"
    PARK = "park"
    HOME = "find home"
    MOVE = "MoveAxis"
    STOP = "stop"
    FOLLOW = "satellite pass"  # a target followed with axis speeds (follow.py)


class Phase(Enum):
    QUEUED = "queued"  # accepted (Slewing true); waiting for the motion it replaces to brake to rest
    MOVING = "moving"  # the mount is carrying out the command
    LANDING = "landing"  # fine correction: a residual pulse or waiting for the freeze instant
    SETTLING = "settling"  # commanded motion over; waiting for the readings to show rest
    SETTLE_TIME = "settle time"  # at rest; the client's SlewSettleTime is running


@dataclass
class Landing:
    """How a slew ends exactly where asked (see the module docstring)."""

    ground: bool  # a point fixed to the ground (HA/Dec) rather than to the sky (RA/Dec)
    ra: float  # sky target (hours) when not ground
    ha: float  # ground target (hours) when ground
    dec: float
    freeze: bool  # ground target and tracking must be off at the end
    wire: tuple[float, float] = (0.0, 0.0)  # what the mount was sent (RA h, Dec deg)
    t_star: float | None = None  # mount time at which the pointing matches (ground)
    attempts: int = 0
    pulse_end: float = 0.0  # mount time the residual pulses end (sky)


#: A target: UTC -> (RA hours, Dec degrees) in the client's frame. Raises ValueError where it has no place.
Target = Callable[[datetime], tuple[float, float]]

#: The lead before the first measurement: one tick plus the write of two speed changes at 9600 baud.
INITIAL_LEAD_S = TICK_S + 0.035
#: Once the error stays under this (degrees) the target counts as acquired: the figures start there.
ACQUIRED_DEG = 3.0 / 60.0


@dataclass
class Follow:
    """One follow: what is followed, its phase, and what the page and the Action read back."""

    name: str
    target: Target
    enters: datetime  # the target enters the allowed sky
    aim: datetime  # the point the mount waits at: the target's place then (a little inside the allowed sky)
    leaves: datetime  # the follow ends: the target leaves the allowed sky (or the side's reach)
    # A planned meridian flip (telescope/passes.py FlipLeg): at ``flip_at`` a GOTO to where the target will
    # be at ``resumes`` takes the mount to ``flip_side`` ("pierEast"/"pierWest"); None: one leg only.
    flip_at: datetime | None = None
    resumes: datetime | None = None
    flip_side: str = ""
    # Why a GOTO to (RA h, Dec deg) landing in the given seconds is refused (the one GoTo limit check), or None.
    blocked: Callable[[float, float, float], str | None] = lambda ra, dec, slew_s: None
    # aiming (the GOTO), waiting (holding the aim point), following, flipping (the flip's stop and GOTO), ended
    phase: str = "aiming"
    ended: str = ""  # why it ended ('' while it runs)
    leg: int = 1  # 2 once the flip has begun
    goto_sent: float | None = None  # mount time the GOTO of this leg was written (None: not yet)
    goto_busy: bool = False  # the mount's flags have shown that GOTO running
    flip_deadline: float = 0.0  # mount time after which a flip GOTO refused as "braking" (e3) is given up
    lead_s: float = INITIAL_LEAD_S
    speeds: list[float] = field(default_factory=lambda: [0.0, 0.0])  # sky deg/s sent: RA (+ east), Dec
    error_deg: float | None = None  # the last pointing error
    acquired: datetime | None = None
    reacquired: datetime | None = None  # the second leg's acquisition after a flip
    squares: float = 0.0  # of the errors after acquisition (deg²), re-acquisition after a flip left out
    samples: int = 0
    worst_deg: float = 0.0

    @property
    def rms_deg(self) -> float | None:
        return math.sqrt(self.squares / self.samples) if self.samples else None

    @property
    def shown_phase(self) -> str:
        """The phase as the page and the Action say it: the flip names the side it goes to."""
        return f"flipping to {self.flip_side}" if self.phase == "flipping" else self.phase

    def note_error(self, now: datetime, error_deg: float) -> None:
        self.error_deg = error_deg
        if self.acquired is None and error_deg <= ACQUIRED_DEG:
            self.acquired = now
        if self.leg == 2 and self.reacquired is None and error_deg <= ACQUIRED_DEG:
            self.reacquired = now
        if self.acquired is not None and (self.leg == 1 or self.reacquired is not None):
            self.squares += error_deg * error_deg
            self.samples += 1
            self.worst_deg = max(self.worst_deg, error_deg)


@dataclass
class Motion:
    kind: MotionKind
    generation: int
    started: float  # mount time
    phase: Phase = Phase.MOVING
    saw_busy: bool = False
    landing: Landing | None = None
    rest_from: float = 0.0  # readings taken after this mount time count toward rest
    brake_s: float = 0.0  # braking time predicted at the stop
    at_rest: float | None = None
    restore_tracking: bool | None = None  # set tracking to this at arrival (alt/az, park)
    queued: bool = False  # it replaced a motion, so its command may meet the mount still braking
    done: threading.Event = field(default_factory=threading.Event)
    error: str = ""  # why it ended short: a failure, or one of INTERRUPTIONS
    follow: Follow | None = None  # what a FOLLOW motion follows (follow.py)


#: ``Motion.error`` values for a motion that did not fail but was ended by a client, and what a
#: synchronous caller is told (it must never read success: the mount is not where it asked).
INTERRUPTIONS = {
    "stopped": "it was stopped (AbortSlew, or a stop from another client) before it arrived",
    "replaced": "another slew replaced it before it arrived",
}


@dataclass
class ManualMove:
    rate: float  # sky deg/s: axis 0 + is east (RA up), axis 1 + is north
    owner: ClientKey | None


@dataclass
class Pulse:
    """A guide pulse sent in chunks of at most 3 s: ``remaining_ms`` not yet sent, and the mount time
    by which the whole pulse should be over (a link failure may cost pulse time, nothing else may).
    In alt-az mode the whole pulse is one chunk (a timed move, see ``guiding.py``)."""

    direction: Direction
    remaining_ms: int
    deadline: float
    chunk_end: float


@dataclass(frozen=True)
class TimedMove:
    """An alt-az pulse under way on one axis (mount times)."""

    start: float  # the move command was written (on an idle line)
    end: float  # due to stop


def pulse_axis(direction: Direction) -> int:
    """0 for the RA axis (east/west), 1 for Dec (north/south)."""
    return 0 if direction in (Direction.EAST, Direction.WEST) else 1


def direction_sign(direction: Direction) -> float:
    """+1 for east and north (the axes' positive senses), -1 for west and south."""
    return 1.0 if direction in (Direction.EAST, Direction.NORTH) else -1.0


class Generation:
    """The stop generation: every stop and every new start bumps it, and every motion command
    carries a guard ("still this generation") that the link checks right before writing, so a
    command racing a stop is either written before the stop or never.

    Owned by MotionSupervisor; :meth:`bump` is called only with the supervisor's ``_lock`` held.
    Its parts read :attr:`value` and build guards without a lock (an int read is atomic)."""

    def __init__(self) -> None:
        self.value = 0

    def bump(self) -> int:
        """Withdraw every command guarded with an older generation; the new value (callers hold
        MotionSupervisor._lock)."""
        self.value += 1
        return self.value

    def guard(self, generation: int | None = None) -> Callable[[], bool]:
        """A guard that holds while the generation is still ``generation`` (None: the value now)."""
        expected = self.value if generation is None else generation
        return lambda: self.value == expected


def _wrap12(hours: float) -> float:
    return (hours + 12.0) % 24.0 - 12.0
