"""Guide pulses: the clients' PulseGuide, and the pulses landing and rate offsets are made of.

In equatorial mode a pulse is the mount's own ``:Mg``: the mount times it, at most 3 s at a time,
so longer client pulses are sent in chunks. In alt-az mode ``:Mg`` is accepted but moves nothing
(PT measured 200-2000 ms pulses: field notes §2.5), while the mount's moves (``:Me/:Mw/:Mn/:Ms#``)
keep their sky meaning there (east/west in RA, north/south in Dec, on top of tracking). So in alt-az a
pulse is a *timed move*: the variable rate set to the guide speed (``:Rv``), the move started, and the
supervisor stops it (``:Q?#`` on the urgent lane) when the pulse's time is up. Its length is then timed
by the host, to a few milliseconds (0.02″ at the default guide speed), and needs no chunks.

One timed move per axis, like one ``:Mg`` per axis on the mount: a new pulse on an axis replaces the
running one. Its start and its stop are both written on an idle line (:meth:`Mount.drift`), so each
reaches the mount its own four bytes after the instant recorded, on a line paced at 9600 baud or on
one that ignores the baud: the pulse the mount makes is the one measured. A timed move may still
run a little longer than asked (the supervisor's wake-up; a stop waiting for the other axis's start
to leave the line, up to ~25 ms at 9600 baud: 0.2″ at the guide speed). Rate offsets in alt-az are
not paid in pulses but by a modulated move (offsets.py).

Every stop (AbortSlew, a new slew, the last client leaving, shutdown, a safety stop) ends timed moves
with everything else; a timed move that cannot be stopped triggers a safety stop.
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

from .._exceptions import (
    InvalidOperation,
    LinkError,
    MotionCancelled,
    MountReplyError,
    ProtocolError,
    driver_error,
)
from ..mount.operations import PULSE_CHUNK_MS, Mount
from ..sky import SIDEREAL_DEG_S
from ..zwo.wire_values import Direction
from .kinds import Motion, MotionKind, Pulse

if TYPE_CHECKING:
    import threading

    from .offsets import RateOffsets

log = logging.getLogger(__name__)


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


class GuidingMixin:
    """The guide-pulse part of MotionSupervisor."""

    mount: Mount
    motion: Motion | None
    pulses: dict[int, Pulse]
    timed_moves: dict[int, TimedMove]  # axis -> the alt-az pulse move running there
    offsets: RateOffsets
    generation: int
    _start_lock: threading.Lock
    _lock: threading.Lock
    _timed_lock: threading.Lock  # one timed-move start or end at a time (held across its I/O)

    if TYPE_CHECKING:  # provided by MotionSupervisor
        def _guard(self, generation: int) -> Callable[[], bool]: ...
        def _notify(self) -> None: ...
        def safety_stop(self, why: str) -> None: ...

    # -- one pulse, as the mount can make it -----------------------------------------------------

    def _guide_pulse(self, direction: Direction, milliseconds: int, guard: Callable[[], bool] | None = None) -> float:
        """Send one pulse (≤ 3000 ms in equatorial mode, any length in alt-az); return its end in
        mount time. Raises what the link raises; MotionCancelled if ``guard`` withdrew it."""
        state = self.mount.state
        if not state.altaz:
            return self.mount.pulse_guide(direction, milliseconds, guard=guard)
        axis = pulse_axis(direction)
        with self._timed_lock:
            start = self.mount.drift(axis, direction_sign(direction) * state.guide_rate * SIDEREAL_DEG_S,
                                     guard=guard)  # when the move command was written
            self.offsets.handover(axis, start)  # an offset move there ended as this one began
            move = TimedMove(start, start + milliseconds / 1000.0)
            with self._lock:
                self.timed_moves[axis] = move
        self._notify()
        return move.end

    def _tick_timed_moves(self, now: float) -> None:
        """Stop the alt-az pulse moves whose time is up."""
        for axis, move in list(self.timed_moves.items()):
            if now >= move.end:
                self._end_timed_move(axis, move)

    def _end_timed_move(self, axis: int, move: TimedMove | None = None) -> None:
        """Stop one timed move (``move``: only if it is still that one, not a newer pulse's). The check
        and the stop are one step under ``_timed_lock``, so a pulse started meanwhile is never cut."""
        with self._timed_lock:
            with self._lock:
                running = self.timed_moves.get(axis)
                if running is None or (move is not None and running is not move):
                    return
                del self.timed_moves[axis]
            try:
                self.mount.drift(axis, 0.0)
            except (LinkError, ProtocolError, MountReplyError) as exc:
                failure = exc
            else:
                return
        self.safety_stop(f"ending an alt-az guide pulse on axis {axis} failed: {failure}")

    # -- the clients' PulseGuide -----------------------------------------------------------------

    def pulse(self, direction: Direction, duration_ms: int) -> None:
        """Start a guide pulse of any length (sent in chunks the mount accepts)."""
        if self.motion is not None and self.motion.kind is not MotionKind.STOP:
            raise InvalidOperation(f"cannot pulse guide during a {self.motion.kind.value}")
        if duration_ms == 0:
            return
        axis = pulse_axis(direction)
        chunk = duration_ms if self.mount.state.altaz else min(duration_ms, PULSE_CHUNK_MS)
        with self._start_lock:
            self.offsets.refund(axis, self.mount.monotonic())  # this pulse replaces any offset pulse
            generation = self.generation
            try:
                end = self._guide_pulse(direction, chunk, guard=self._guard(generation))
            except (MountReplyError, ProtocolError, LinkError, MotionCancelled) as exc:
                if isinstance(exc, MotionCancelled):
                    raise InvalidOperation("PulseGuide cancelled: a stop arrived while it was starting") from exc
                raise driver_error("PulseGuide", exc) from exc
            with self._lock:
                if self.generation == generation:
                    self.pulses[axis] = Pulse(direction, duration_ms - chunk,
                                              end - chunk / 1000.0 + duration_ms / 1000.0, end)
        self._notify()

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
                end = self._guide_pulse(pulse.direction, chunk, guard=self._guard(generation))
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
