"""MotionSupervisor: the one owner of every motion of one mount.

GOTOs, alt/az and park slews, home, MoveAxis, guide pulses, aborts, the MoveAxis watchdog, the
horizon and meridian limits and the shutdown stop all live here, so every program that moves the
mount (Alpaca, the bridges, the setup page) gets the same rules, and a stop from any of them stops
motion started by any other. ``Telescope`` maps Alpaca members onto this; bytes live in ``mount``.

Lock rules (the reason this module exists):

- ``_start_lock`` serialises motion *starts* (GOTO, MoveAxis, home, park, pulses). It may be held
  across serial I/O and waits. **Stop paths never take it.**
- ``_lock`` guards this object's fields. It is never held across I/O or a wait.
- The link's write lock is held only for one ``write``. A stop bumps :attr:`generation` under
  ``_lock`` and then writes its reply-less ``:Q#`` through the link's urgent lane; every motion
  command carries a guard ("generation unchanged") that the link checks under its write lock right
  before writing. So a motion racing a stop is either never written or written before the stop:
  an abort can never be overtaken by the GOTO it meant to cancel.

Rest, not flags: the mount drops its "slewing" flag the moment a GOTO ends or ``:Q#`` arrives,
while the axes may still brake for seconds. A motion therefore ends only when the readings taken
after it show the mount at rest (consecutive positions stable in the frame the mount holds still:
RA/Dec while tracking, HA/Dec when not) *and* the braking time predicted from its last speed has
passed. Slewing stays true until then.

Landing: the mount takes targets in whole seconds of RA and whole arcseconds, and a slew to a
point fixed to the ground (Alt/Az, a custom park) chases a sky that turns during the slew. A sky
target is reached exactly by a short guide pulse for the rounding residual after arrival. A ground
target is aimed at a whole-second RA the point will have at a known instant t* just after arrival;
the mount tracks until t*, and tracking is switched off at t* exactly (the line is held and the
``:Td#`` written at t*), which freezes the pointing on the requested Alt/Az. If the mount arrives
too late for t*, a short correcting GOTO aims at a new t*.
"""

from __future__ import annotations

import itertools
import logging
import math
import threading
import time
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from enum import Enum

from . import sky
from ._exceptions import (
    AlpacaError,
    AmbiguousReply,
    DriverError,
    InvalidOperation,
    LinkError,
    LinkTimeout,
    MotionCancelled,
    MountReplyError,
    ProtocolError,
)
from .clients import ClientKey, ClientRegistry
from .config import Settings, horizon_altitude_at
from .mount import PULSE_CHUNK_MS, Mount, MountState
from .protocol import Direction
from .sky import SIDEREAL_DEG_S, SIDEREAL_HOURS_PER_S

log = logging.getLogger(__name__)

#: The mount's status flags can lag a command by ~0.5 s (field notes §5.1).
STATUS_LAG_S = 1.0
MAX_MOTION_S = 600.0
#: Braking deceleration of the axes (deg/s²): the emulator's, and the AM5's observed order of size.
DECELERATION_DEG_S2 = 3.0
#: A GOTO takes about this long per degree plus a fixed part; aims ground targets at arrival.
SLEW_S_PER_DEG = 1 / 5.0
SLEW_S_FIXED = 3.0
#: How far after the predicted arrival a ground target's freeze instant is placed (mount s).
LANDING_MARGIN_S = 1.0
#: Lead for a short correcting GOTO (mount s): it must arrive before its freeze instant.
CORRECTION_LEAD_S = 2.5
#: Real seconds the server needs to see an arrival (a fast poll and a supervisor tick), added to
#: the leads above in mount time, so a fast emulator is aimed as well as a real mount.
SEE_ARRIVAL_REAL_S = 0.6
MAX_LANDING_ATTEMPTS = 3
#: Residuals smaller than this (ms of guide pulse) are not worth a pulse.
MIN_PULSE_MS = 5
#: Rest: consecutive readings within these of each other in the frame the mount holds still.
REST_RA_S = 1.5  # seconds of RA: the mount prints whole seconds
REST_DEC_ARCSEC = 1.5
REST_READINGS = 3
#: Wall-clock period of the supervisor loop (real seconds).
TICK_S = 0.1
#: Reaction allowance for a limit stop on top of the braking distance, in supervisor ticks.
LIMIT_TICKS = 2.0


class MotionKind(Enum):
    GOTO = "slew"
    ALTAZ = "slew to alt/az"
    PARK = "park"
    HOME = "find home"
    MOVE = "MoveAxis"
    STOP = "stop"


class Phase(Enum):
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
    done: threading.Event = field(default_factory=threading.Event)
    error: str = ""


@dataclass
class ManualMove:
    rate: float  # sky deg/s: axis 0 + is east (RA up), axis 1 + is north
    owner: ClientKey | None


@dataclass
class Pulse:
    """A guide pulse sent in chunks of at most 3 s: ``remaining_ms`` not yet sent, and the mount time
    by which the whole pulse should be over (a link failure may cost pulse time, nothing else may)."""

    direction: Direction
    remaining_ms: int
    deadline: float
    chunk_end: float


@dataclass(frozen=True)
class Reading:
    t: float
    ra: float
    dec: float
    tracking: bool


def _wrap12(hours: float) -> float:
    return (hours + 12.0) % 24.0 - 12.0


# DriverError numbers, so scripts can tell the cases apart.
ERR_LINK = 0x500
ERR_MOUNT_REFUSED = 0x501
ERR_MOUNT_PROTOCOL = 0x502
ERR_TIMEOUT = 0x503


def _mount_errors(what: str, exc: Exception) -> AlpacaError:
    """The DriverError a client should see for a link or mount failure."""
    if isinstance(exc, MountReplyError):
        return DriverError(f"{what}: the mount refused: {exc.meaning or exc.reply}", ERR_MOUNT_REFUSED)
    if isinstance(exc, ProtocolError):
        return DriverError(f"{what}: garbled reply from the mount: {exc}", ERR_MOUNT_PROTOCOL)
    return DriverError(f"{what}: mount link problem: {exc}", ERR_LINK)


class MotionSupervisor:
    """Starts, watches, lands and stops every motion of one mount (see the module docstring)."""

    def __init__(
        self,
        mount: Mount,
        settings: Callable[[], Settings],
        lst: Callable[[], float],
        registry: ClientRegistry,
        *,
        name: str = "motion",
    ) -> None:
        self.mount = mount
        self._settings = settings
        self._lst = lst
        self.registry = registry
        self._start_lock = threading.Lock()
        self._lock = threading.Lock()
        self._wake = threading.Condition()
        self.generation = 0
        self.motion: Motion | None = None
        self.moves: dict[int, ManualMove] = {}
        self.pulses: dict[int, Pulse] = {}
        self.settle_s = 0.0
        self.parked = False
        self._readings: deque[Reading] = deque(maxlen=8)
        self._stop_pending = ""  # why a safety stop is still owed to the mount ('' = none)
        self._stopped = threading.Event()
        self._thread = threading.Thread(target=self._run, name=name, daemon=True)
        self._thread.start()

    # -- read-outs ---------------------------------------------------------------------------

    def slewing(self, state: MountState | None = None) -> bool:
        """Our motions until the mount is at rest, manual moves, and any GOTO the mount reports."""
        state = state or self.mount.state
        return self.motion is not None or bool(self.moves) or bool(state.moving_axes) or state.goto_running

    def pulse_guiding(self) -> bool:
        return bool(self.pulses)

    def busy_with(self) -> str:
        motion = self.motion
        return motion.kind.value if motion is not None else ""

    # -- stops (no lock held across I/O; never waits) ------------------------------------------

    def abort(self, why: str = "AbortSlew") -> None:
        """Stop every motion now: bump the generation (withdrawing motions being started), write
        :Q# on the urgent lane, and keep Slewing true until the readings show the mount at rest."""
        state = self.mount.state
        with self._lock:
            self.generation += 1
            previous = self.motion
            speed = self._speed_estimate()
            moving = previous is not None or self.moves or state.moving_axes or state.goto_running
            self.moves.clear()
            self.pulses.clear()
            self.motion = self._stopping(speed, previous) if moving else None
        try:
            self.mount.stop()
            self._stop_pending = ""
        except LinkError as exc:
            self._stop_pending = why
            raise _mount_errors(why, exc) from exc
        finally:
            self._notify()
        log.info("%s: mount stopped (was %s)", why, previous.kind.value if previous else "idle")

    def _stopping(self, speed: float, previous: Motion | None) -> Motion:
        """A STOP motion that lasts until the mount is at rest (callers hold ``_lock``)."""
        now = self.mount.monotonic()
        motion = Motion(MotionKind.STOP, self.generation, now, Phase.SETTLING, rest_from=now,
                        brake_s=speed / DECELERATION_DEG_S2)
        if previous is not None:
            previous.error = previous.error or "stopped"
            previous.done.set()
        return motion

    def stop_axis(self, axis: int, why: str) -> None:
        """MoveAxis(axis, 0) and the watchdog: stop one axis on the urgent lane."""
        with self._lock:
            move = self.moves.pop(axis, None)
            self.generation += 1
            if not self.moves and (self.motion is None or self.motion.kind is MotionKind.MOVE):
                speed = max(abs(move.rate) if move else 0.0, self._speed_estimate())
                self.motion = self._stopping(speed, self.motion)
        try:
            self.mount.move_axis(axis, 0.0)
        except (LinkError, ProtocolError, MountReplyError) as exc:
            self.safety_stop(f"{why} (stopping axis {axis} failed: {exc})")
        finally:
            self._notify()
        if why:
            log.info("axis %d stopped: %s", axis, why)

    def stop_manual(self, why: str) -> None:
        """Stop manual moves and pulses (last client gone, server shutting down)."""
        if not self.moves and not self.mount.state.moving_axes and not self.pulses:
            return
        log.warning("stopping manual motion: %s", why)
        with self._lock:
            self.pulses.clear()
        for axis in (0, 1):
            if axis in self.moves or axis in self.mount.state.moving_axes:
                self.stop_axis(axis, "")

    def safety_stop(self, why: str) -> None:
        """Send :Q# now, and keep retrying from the supervisor until the mount has taken it."""
        try:
            self.mount.stop()
            self._stop_pending = ""
            log.warning("mount stopped: %s", why)
        except (LinkError, ProtocolError) as exc:
            if not self._stop_pending:
                log.error("could not stop the mount (%s): %s; retrying until it answers", why, exc)
            self._stop_pending = why

    # -- starts ------------------------------------------------------------------------------

    def _guard(self, generation: int) -> Callable[[], bool]:
        return lambda: self.generation == generation

    def _begin(self, kind: MotionKind) -> Motion:
        """Replace whatever moves now by a new motion (callers hold ``_start_lock``)."""
        with self._lock:
            self.generation += 1
            generation = self.generation
        self._stop_previous(generation)
        with self._lock:
            if self.generation != generation:
                raise InvalidOperation(f"{kind.value} cancelled: a stop arrived while it was starting")
            motion = Motion(kind, generation, self.mount.monotonic())
            previous, self.motion = self.motion, motion
            self.moves.clear()
        if previous is not None:
            previous.error = previous.error or "replaced"
            previous.done.set()
        return motion

    def _stop_previous(self, generation: int) -> None:
        """A new slew replaces the running one: :Q#, then wait for the mount to drop its GOTO flag
        (a GOTO during a GOTO gets e3#). The wait gives up at once if a stop arrives."""
        state = self.mount.state
        if self.motion is None and not self.moves and not state.moving_axes and not state.goto_running:
            return
        try:
            self.mount.stop()
        except LinkError as exc:
            raise _mount_errors("stopping the current motion", exc) from exc
        since = self.mount.monotonic()
        self.mount.refresh()
        idle = self.mount.wait_for(
            lambda s: self.generation != generation
            or (s.status_time is not None and s.status_time > since and not s.goto_running),
            timeout=10.0,
        )
        if idle is None:
            raise DriverError("the mount did not stop the previous motion", ERR_TIMEOUT)

    def _fail(self, motion: Motion, what: str, exc: Exception) -> AlpacaError:
        with self._lock:
            if self.motion is motion:
                self.motion = None
        motion.done.set()
        if isinstance(exc, MotionCancelled):
            return InvalidOperation(f"{what} cancelled: a stop arrived while it was starting")
        return _mount_errors(what, exc)

    def goto(self, ra: float, dec: float, kind: MotionKind = MotionKind.GOTO,
             restore_tracking: bool | None = None) -> Motion:
        """Slew to a sky position (RA/Dec), landing on it exactly."""
        with self._start_lock:
            motion = self._begin(kind)
            motion.landing = Landing(False, ra % 24.0, 0.0, dec, False)
            motion.restore_tracking = restore_tracking
            self._send_goto(motion, ra, dec)
        return motion

    def goto_fixed(self, ha: float, dec: float, kind: MotionKind, freeze: bool) -> Motion:
        """Slew to a point fixed to the ground (HA/Dec), landing on it at a known instant."""
        with self._start_lock:
            motion = self._begin(kind)
            landing = Landing(True, 0.0, _wrap12(ha), dec, freeze)
            motion.landing = landing
            here = self.mount.position()
            lst = self._lst()
            distance = 0.0 if here is None else sky.angular_separation(
                sky.ra_from_hour_angle(lst, ha), dec, *here)
            ra = self._aim(landing, SLEW_S_FIXED + distance * SLEW_S_PER_DEG + LANDING_MARGIN_S + self._see_arrival())
            self._send_goto(motion, ra, dec)
        return motion

    def _see_arrival(self) -> float:
        return SEE_ARRIVAL_REAL_S * self.mount.clock_rate

    def _aim(self, landing: Landing, lead_s: float) -> float:
        """Pick the whole-second RA the ground point will have ``lead_s`` or a little more from now,
        and record the instant t* at which it has it."""
        now = self.mount.monotonic()
        lst_at = self._lst() + lead_s * SIDEREAL_HOURS_PER_S
        ra_exact = (lst_at - landing.ha) % 24.0
        ra_wire = math.ceil(ra_exact * 3600.0 - 1e-9) / 3600.0
        landing.t_star = now + lead_s + (ra_wire - ra_exact) / SIDEREAL_HOURS_PER_S
        return ra_wire % 24.0

    def _send_goto(self, motion: Motion, ra: float, dec: float) -> None:
        guard = self._guard(motion.generation)
        try:
            wire = self.mount.goto(ra, dec, guard=guard)
        except (LinkTimeout, AmbiguousReply) as exc:
            # The reply was lost or garbled, not necessarily the command: the mount may be slewing.
            # Keep the motion under supervision; the readings end it when they show the mount idle.
            self._notify()
            raise DriverError(f"{motion.kind.value}: the mount did not confirm the GOTO ({exc}); Slewing "
                              "shows whether it started", ERR_TIMEOUT) from exc
        except (MountReplyError, ProtocolError, LinkError, MotionCancelled) as exc:
            raise self._fail(motion, motion.kind.value, exc) from exc
        assert motion.landing is not None
        motion.landing.wire = wire
        motion.landing.attempts += 1
        self._notify()

    def home(self, kind: MotionKind = MotionKind.HOME) -> Motion:
        with self._start_lock:
            motion = self._begin(kind)
            try:
                self.mount.home(guard=self._guard(motion.generation))
            except (MountReplyError, ProtocolError, LinkError, MotionCancelled) as exc:
                raise self._fail(motion, kind.value, exc) from exc
        self._notify()
        return motion

    def move_axis(self, axis: int, rate: float, owner: ClientKey | None) -> None:
        """Start (rate != 0) or stop (0) a manual move of one axis."""
        if rate == 0.0:
            self.stop_axis(axis, "")
            return
        with self._start_lock:
            motion = self.motion
            if motion is not None and motion.kind not in (MotionKind.MOVE, MotionKind.STOP):
                raise InvalidOperation(f"a {motion.kind.value} is in progress; abort it first")
            self._check_move_allowed(axis, rate)
            with self._lock:
                generation = self.generation
                if motion is None or motion.kind is MotionKind.STOP:
                    self.motion = Motion(MotionKind.MOVE, generation, self.mount.monotonic())
            try:
                self.mount.move_axis(axis, rate, guard=self._guard(generation))
            except (MountReplyError, ProtocolError, LinkError, MotionCancelled) as exc:
                with self._lock:
                    if not self.moves and self.motion is not None and self.motion.kind is MotionKind.MOVE:
                        self.motion = None
                if isinstance(exc, MotionCancelled):
                    raise InvalidOperation("MoveAxis cancelled: a stop arrived while it was starting") from exc
                raise _mount_errors("MoveAxis", exc) from exc
            with self._lock:
                self.moves[axis] = ManualMove(rate, owner)
        self._notify()

    def pulse(self, direction: Direction, duration_ms: int) -> None:
        """Start a guide pulse of any length (sent in chunks the mount accepts)."""
        if self.motion is not None and self.motion.kind is not MotionKind.STOP:
            raise InvalidOperation(f"cannot pulse guide during a {self.motion.kind.value}")
        if duration_ms == 0:
            return
        axis = 0 if direction in (Direction.EAST, Direction.WEST) else 1
        chunk = min(duration_ms, PULSE_CHUNK_MS)
        with self._start_lock:
            generation = self.generation
            try:
                end = self.mount.pulse_guide(direction, chunk, guard=self._guard(generation))
            except (MountReplyError, ProtocolError, LinkError, MotionCancelled) as exc:
                if isinstance(exc, MotionCancelled):
                    raise InvalidOperation("PulseGuide cancelled: a stop arrived while it was starting") from exc
                raise _mount_errors("PulseGuide", exc) from exc
            with self._lock:
                if self.generation == generation:
                    self.pulses[axis] = Pulse(direction, duration_ms - chunk,
                                              end - chunk / 1000.0 + duration_ms / 1000.0, end)
        self._notify()

    def wait(self, motion: Motion, timeout: float = MAX_MOTION_S) -> None:
        """Block until ``motion`` has ended (synchronous Alpaca slews)."""
        if not motion.done.wait(timeout):
            raise DriverError(f"the {motion.kind.value} did not finish in time", ERR_TIMEOUT)
        if motion.error not in ("", "stopped", "replaced"):
            raise DriverError(f"the {motion.kind.value} failed: {motion.error}", ERR_LINK)

    def _check_move_allowed(self, axis: int, rate: float) -> None:
        """Refuse a manual move that would have to stop at once (already at a limit, heading on)."""
        limit = self._limit_reached({axis: rate}, self.mount.state)
        if limit:
            raise InvalidOperation(f"MoveAxis refused: {limit}")

    # -- the supervisor thread -----------------------------------------------------------------

    def close(self) -> None:
        self._stopped.set()
        self._notify()
        self._thread.join(timeout=2)

    def _notify(self) -> None:
        with self._wake:
            self._wake.notify_all()

    def _run(self) -> None:
        while not self._stopped.is_set():
            with self._wake:
                self._wake.wait(self._next_wake())
            if self._stopped.is_set():
                return
            try:
                self._tick()
            except Exception:  # the supervisor must survive anything to keep the mount safe
                log.exception("motion supervisor error")

    def _next_wake(self) -> float:
        """Real seconds to wait: TICK_S at most, sooner when a pulse chunk or a landing is due."""
        now = self.mount.monotonic()
        rate = self.mount.clock_rate
        delays = [TICK_S]
        delays.extend(max(0.0, pulse.chunk_end - now) / rate for pulse in self.pulses.values())
        motion = self.motion
        landing = motion.landing if motion is not None and motion.phase is Phase.LANDING else None
        if landing is not None and landing.t_star is not None:
            delays.append(max(0.0, (landing.t_star - now) / rate - 0.05))
        return min(delays)

    def _tick(self) -> None:
        if not self.mount.running:
            return
        if self._stop_pending:
            self.safety_stop(self._stop_pending)
        state = self.mount.state
        self._record_reading(state)
        now = self.mount.monotonic()
        self._tick_pulses(now)
        self._tick_motion(now, state)
        self._tick_watchdog()
        self._tick_limits(state)

    def _record_reading(self, state: MountState) -> None:
        if state.raw_ra is None or state.raw_dec is None or state.position_time is None:
            return
        if self._readings and self._readings[-1].t >= state.position_time:
            return
        tracking = bool(state.tracking and state.tracking.on)
        self._readings.append(Reading(state.position_time, state.raw_ra, state.raw_dec, tracking))

    def _tick_pulses(self, now: float) -> None:
        """Send the next chunk of long pulses. If the link is down, retry until the pulse's own end:
        the mount carries on with the chunk it has, and the rest goes out once the link is back."""
        for axis, pulse in list(self.pulses.items()):
            if now < pulse.chunk_end:
                continue
            if pulse.remaining_ms < 10:
                with self._lock:
                    if self.pulses.get(axis) is pulse:
                        del self.pulses[axis]
                continue
            chunk = min(pulse.remaining_ms, PULSE_CHUNK_MS)
            generation = self.generation
            try:
                end = self.mount.pulse_guide(pulse.direction, chunk, guard=self._guard(generation))
            except MotionCancelled:
                continue
            except (LinkError, ProtocolError, MountReplyError) as exc:
                # What the link outage took is lost; the rest still ends by the pulse's deadline.
                left = min(pulse.remaining_ms, int((pulse.deadline - now) * 1000.0))
                log.warning("pulse continuation failed (%s); retrying with %d ms left", exc, left)
                replacement = Pulse(pulse.direction, left, pulse.deadline, now + 0.05)
            else:
                replacement = Pulse(pulse.direction, pulse.remaining_ms - chunk, pulse.deadline, end)
            with self._lock:
                if self.pulses.get(axis) is pulse:
                    self.pulses[axis] = replacement

    # -- motion phases -------------------------------------------------------------------------

    def _tick_motion(self, now: float, state: MountState) -> None:
        motion = self.motion
        if motion is None:
            return
        if now - motion.started > MAX_MOTION_S and motion.kind is not MotionKind.MOVE:
            log.error("%s did not finish within %.0f s: stopping", motion.kind.value, MAX_MOTION_S)
            motion.error = "did not finish in time"
            self.safety_stop(f"{motion.kind.value} overran")
            self._finish(motion)
            return
        if motion.phase is Phase.MOVING:
            self._tick_moving(motion, now, state)
        elif motion.phase is Phase.LANDING:
            self._tick_landing(motion, now)
        elif motion.phase is Phase.SETTLING:
            if motion.kind is MotionKind.MOVE:
                return  # manual moves settle through their STOP motion
            if self._at_rest(motion, now):
                motion.at_rest = now
                motion.phase = Phase.SETTLE_TIME
        settle_s = 0.0 if motion.kind is MotionKind.STOP else self.settle_s
        settled = motion.at_rest is not None and now - motion.at_rest >= settle_s
        if motion.phase is Phase.SETTLE_TIME and settled:
            self._finish(motion)

    def _tick_moving(self, motion: Motion, now: float, state: MountState) -> None:
        if motion.kind is MotionKind.MOVE:
            return
        if state.status_time is None or state.status_time <= motion.started or state.status is None:
            return  # no reading taken after the command yet
        if state.status.slewing:
            motion.saw_busy = True
            return
        if not motion.saw_busy and state.status_time - motion.started < STATUS_LAG_S:
            return  # the flags may still show the state from before the command
        self._arrived(motion, now)

    def _arrived(self, motion: Motion, now: float) -> None:
        """The mount says the slew is over: start the landing, or settle."""
        landing = motion.landing
        if landing is not None and self.mount.running:
            try:
                if landing.ground:
                    self._land_ground(motion, landing, now)
                else:
                    self._land_sky(motion, landing, now)
                return
            except (LinkError, ProtocolError, MountReplyError, MotionCancelled) as exc:
                log.warning("%s: fine landing skipped: %s", motion.kind.value, exc)
        self._after_arrival(motion)
        self._settle(motion, now)

    def _land_sky(self, motion: Motion, landing: Landing, now: float) -> None:
        """Pulse away the whole-second/arcsecond rounding of the target the mount was given."""
        guide_deg_s = self.mount.state.guide_rate * SIDEREAL_DEG_S
        d_ra_deg = _wrap12(landing.ra - landing.wire[0]) * 15.0
        d_dec = landing.dec - landing.wire[1]
        end = now
        for delta, positive, negative in ((d_ra_deg, Direction.EAST, Direction.WEST),
                                          (d_dec, Direction.NORTH, Direction.SOUTH)):
            ms = round(abs(delta) / guide_deg_s * 1000.0)
            if ms >= MIN_PULSE_MS:
                direction = positive if delta > 0 else negative
                end = max(end, self.mount.pulse_guide(direction, min(ms, PULSE_CHUNK_MS),
                                                      guard=self._guard(motion.generation)))
        landing.pulse_end = end
        self._after_arrival(motion)
        motion.phase = Phase.LANDING if end > now else Phase.SETTLING
        motion.rest_from = end

    def _land_ground(self, motion: Motion, landing: Landing, now: float) -> None:
        """Wait for t*, or aim a short correcting GOTO at a new t* if the mount arrived too late."""
        assert landing.t_star is not None
        if landing.t_star - now > 0.05 * self.mount.clock_rate:
            motion.phase = Phase.LANDING
            motion.rest_from = now  # readings while it waits for t* show whether it is at rest
            return
        if landing.attempts >= MAX_LANDING_ATTEMPTS:
            log.warning("%s: arrived too late for the landing instant %d times; landing as is",
                        motion.kind.value, landing.attempts)
            self._after_arrival(motion)
            self._settle(motion, now)
            return
        ra = self._aim(landing, CORRECTION_LEAD_S + self._see_arrival())
        log.debug("%s: arrived %.2f s late; correcting GOTO", motion.kind.value, now - landing.t_star)
        motion.saw_busy = False
        motion.started = self.mount.monotonic()
        wire = self.mount.goto(ra, landing.dec, guard=self._guard(motion.generation))
        landing.wire = wire
        landing.attempts += 1
        motion.phase = Phase.MOVING

    def _tick_landing(self, motion: Motion, now: float) -> None:
        landing = motion.landing
        assert landing is not None
        if not landing.ground:
            if now >= landing.pulse_end:
                self._settle(motion, now)
            return
        assert landing.t_star is not None
        rate = self.mount.clock_rate
        if (landing.t_star - now) / rate > 0.06:
            if motion.at_rest is None and not landing.freeze and self._at_rest(motion, now):
                motion.at_rest = now  # tracking steadily: the slew can end at t* itself
            return
        at_real = time.monotonic() + (landing.t_star - self.mount.monotonic()) / rate
        if landing.freeze:
            try:
                self.mount.set_tracking(False, guard=self._guard(motion.generation), not_before=at_real)
            except MotionCancelled:
                return
            except (LinkError, ProtocolError, MountReplyError) as exc:
                log.error("%s: could not stop tracking at the landing instant: %s", motion.kind.value, exc)
        else:
            delay = at_real - time.monotonic()
            if delay > 0:
                time.sleep(delay)
        if motion.restore_tracking is True:
            motion.restore_tracking = None  # already tracking: nothing to restore
        self._after_arrival(motion, skip_tracking=landing.freeze)
        if motion.at_rest is not None:
            # Already at rest and tracking: the pointing passes the Alt/Az now, so the slew ends now.
            motion.at_rest = self.mount.monotonic()
            motion.phase = Phase.SETTLE_TIME
            self._tick_motion(motion.at_rest, self.mount.state)
            return
        self._settle(motion, self.mount.monotonic())

    def _after_arrival(self, motion: Motion, skip_tracking: bool = False) -> None:
        wanted = motion.restore_tracking
        if skip_tracking or wanted is None:
            return
        try:
            self.mount.set_tracking(wanted)
        except (LinkError, ProtocolError, MountReplyError) as exc:
            log.error("after %s: could not set tracking: %s", motion.kind.value, exc)
        motion.restore_tracking = None

    def _settle(self, motion: Motion, now: float) -> None:
        motion.phase = Phase.SETTLING
        motion.rest_from = max(motion.rest_from, now)
        self.mount.refresh()

    def _finish(self, motion: Motion) -> None:
        with self._lock:
            if self.motion is not motion:
                motion.done.set()
                return
            if motion.kind is MotionKind.PARK and not motion.error:
                self.parked = True
                log.info("parked")
            self.motion = None
        motion.done.set()
        self._notify()

    # -- rest ----------------------------------------------------------------------------------

    def _at_rest(self, motion: Motion, now: float) -> bool:
        """Readings after ``rest_from`` stable in the frame the mount holds still, and the
        predicted braking time over. Asks for fresh readings while it waits."""
        if now < motion.rest_from + motion.brake_s:
            self.mount.refresh()
            return False
        recent = [r for r in self._readings if r.t > motion.rest_from]
        if len(recent) < REST_READINGS:
            self.mount.refresh()
            return False
        last = recent[-REST_READINGS:]
        if all(_stable(a, b) for a, b in itertools.pairwise(last)):
            return True
        self.mount.refresh()
        return False

    def _speed_estimate(self) -> float:
        """Fastest axis speed (deg/s) seen in the last two readings, or of the manual moves."""
        speeds = [abs(m.rate) for m in self.moves.values()]
        if len(self._readings) >= 2:
            a, b = self._readings[-2], self._readings[-1]
            dt = b.t - a.t
            if dt > 0:
                d_ra, d_dec = _displacement(a, b)
                speeds.append(max(abs(d_ra), abs(d_dec)) / dt)
        return max(speeds, default=0.0)

    # -- watchdog and limits -------------------------------------------------------------------

    def _tick_watchdog(self) -> None:
        """Stop a MoveAxis whose client stopped talking."""
        limit = self._settings().safety.moveaxis_watchdog_s
        now = time.monotonic()
        for axis, move in list(self.moves.items()):
            if move.owner is None:
                continue
            seen = self.registry.last_seen(move.owner)
            if seen is not None and now - seen > limit:
                self.stop_axis(axis, f"client {move.owner} went silent for {now - seen:.0f} s during MoveAxis")

    def _tick_limits(self, state: MountState) -> None:
        """Stop a manual move before it reaches the horizon, minimum altitude or meridian limit:
        where it would come to rest if stopped now (braking distance plus reaction time)."""
        if not self.moves:
            return
        moves = {axis: move.rate for axis, move in self.moves.items()}
        reason = self._limit_reached(moves, state)
        if reason:
            for axis in list(self.moves):
                self.stop_axis(axis, f"manual move stopped before the limit: {reason}")

    def _limit_reached(self, moves: dict[int, float], state: MountState) -> str:
        position = self.mount.position()
        if position is None or state.position_time is None:
            return ""
        settings = self._settings()
        latitude = settings.site.latitude
        now = self.mount.monotonic()
        age = max(0.0, now - state.position_time)
        react = age + LIMIT_TICKS * TICK_S * self.mount.clock_rate
        ha0 = sky.hour_angle(self._lst(), position[0])
        dec0 = position[1]
        # Sky velocities: a move is relative to the sky, so HA changes by -rate (RA up) only.
        v_ha_deg = -moves.get(0, 0.0)
        v_dec = moves.get(1, 0.0)
        flip_deg = _flip_limit(settings, state)
        for fraction in (0.0, 0.25, 0.5, 0.75, 1.0):
            ha_deg = ha0 * 15.0 + _travel(v_ha_deg, react) * fraction
            dec = dec0 + _travel(v_dec, react) * fraction
            ha, dec = _normalise(ha_deg / 15.0, dec)
            altitude, azimuth = sky.equatorial_to_horizontal(ha, dec, latitude)
            floor = horizon_altitude_at(settings.limits, azimuth)
            if altitude < floor:
                return f"altitude {altitude:.2f}° under the {floor:.2f}° allowed at azimuth {azimuth:.1f}°"
            if flip_deg is not None and state.pier == "W" and v_ha_deg > 0 and ha * 15.0 > flip_deg:
                return f"hour angle {ha * 15.0:.2f}° past the meridian limit {flip_deg:.2f}°"
        return ""


def _travel(velocity: float, react: float) -> float:
    """Signed distance covered if told to stop now: reaction time at speed, then braking."""
    return velocity * react + math.copysign(velocity * velocity / (2.0 * DECELERATION_DEG_S2), velocity)


def _normalise(ha: float, dec: float) -> tuple[float, float]:
    """Bring a Dec carried past a pole back into -90..90 (through the pole the HA turns by 12 h)."""
    if dec > 90.0:
        return _wrap12(ha + 12.0), 180.0 - dec
    if dec < -90.0:
        return _wrap12(ha + 12.0), -180.0 - dec
    return _wrap12(ha), dec


def _flip_limit(settings: Settings, state: MountState) -> float | None:
    """Degrees past the meridian the normal (W) side may go, or None when the mount has none set."""
    limits = settings.limits
    limit = float(limits.meridian_limit_deg)
    return limit if limit < 0.0 or limits.meridian_track_past else 0.0


def _displacement(a: Reading, b: Reading) -> tuple[float, float]:
    """Movement between readings in degrees, in the frame the mount holds still when at rest."""
    dt = b.t - a.t
    d_ra_h = _wrap12(b.ra - a.ra)
    if not b.tracking:
        d_ra_h -= SIDEREAL_HOURS_PER_S * dt  # an idle mount keeps its hour angle: RA grows with LST
    return d_ra_h * 15.0, b.dec - a.dec


def _stable(a: Reading, b: Reading) -> bool:
    d_ra_deg, d_dec = _displacement(a, b)
    return abs(d_ra_deg) <= REST_RA_S * 15.0 / 3600.0 and abs(d_dec) <= REST_DEC_ARCSEC / 3600.0
