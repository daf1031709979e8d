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
import threading
from collections.abc import Callable

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
from .balance import RateOffsets
from .kinds import Generation, Pulse, TimedMove, direction_sign, pulse_axis

log = logging.getLogger(__name__)


class Guiding:
    """Guide pulses and the alt-az timed moves that stand in for them, for one mount.

    Owns ``pulses`` (axis -> the client pulse still being sent in chunks) and ``timed_moves``
    (axis -> the alt-az pulse move running there), and two locks it creates:

    - ``_lock`` guards those two dicts; never held across I/O. Taken after the supervisor's
      ``_lock`` when a stop forgets them (supervisor ``_lock`` -> ``Guiding._lock``), never the
      reverse: nothing here knows the supervisor's locks.
    - ``timed_lock`` makes starting or ending one alt-az timed move, and one speed change of an
      alt-az offset move with its booking (``OffsetPayer``), a single step; held across that one
      move command, then ``_lock`` may be taken inside it (``timed_lock`` -> ``_lock``). Never taken
      by a stop (``abort``'s ``:Q#`` ends every move anyway).

    Lent: ``ledger`` (the supervisor's RateOffsets: a client pulse refunds or hands over the offset
    on its axis) and ``stops`` (the supervisor's Generation, read for guards). ``notify`` wakes the
    supervisor loop; ``safety_stop`` is called when a timed move cannot be stopped."""

    def __init__(self, *, mount: Mount, ledger: RateOffsets, stops: Generation,
                 notify: Callable[[], None], safety_stop: Callable[[str], None]) -> None:
        self.mount = mount
        self._ledger = ledger
        self._stops = stops
        self._notify = notify
        self._safety_stop = safety_stop
        self._lock = threading.Lock()
        self.timed_lock = threading.Lock()
        self.pulses: dict[int, Pulse] = {}
        self.timed_moves: dict[int, TimedMove] = {}

    @property
    def busy(self) -> bool:
        """A client pulse is still being sent, or an alt-az timed move runs."""
        return bool(self.pulses) or bool(self.timed_moves)

    def wake_delays(self, now: float, rate: float) -> list[float]:
        """Real seconds until each pulse chunk and each timed move is due (``rate``: mount clock rate).

        Copies both dicts under ``_lock``: a client's pulse registering meanwhile must not change their
        size mid-iteration, which would raise in the supervisor's thread and end its watchdog and limits."""
        with self._lock:
            pulses, moves = list(self.pulses.values()), list(self.timed_moves.values())
        return [max(0.0, p.chunk_end - now) / rate for p in pulses] + [max(0.0, m.end - now) / rate for m in moves]

    # -- one pulse, as the mount can make it -----------------------------------------------------

    def guide_pulse(self, direction: Direction, milliseconds: int, guard: Callable[[], bool] | None = None) -> float:
        """Send one pulse (≤ 3000 ms in equatorial mode, any length in alt-az); return its end in
        mount time. Raises what the link raises; MotionCancelled if ``guard`` withdrew it."""
        state = self.mount.state
        if not state.altaz:
            return self.mount.pulse_guide(direction, milliseconds, guard=guard)
        axis = pulse_axis(direction)
        with self.timed_lock:
            start = self.mount.drift(axis, direction_sign(direction) * state.guide_rate * SIDEREAL_DEG_S,
                                     guard=guard)  # when the move command was written
            self._ledger.handover(axis, start)  # an offset move there ended as this one began
            move = TimedMove(start, start + milliseconds / 1000.0)
            with self._lock:
                self.timed_moves[axis] = move
        self._notify()
        return move.end

    def tick(self, now: float) -> None:
        """Send the next chunks of long pulses, then stop the timed moves whose time is up."""
        self._tick_pulses(now)
        self._tick_timed_moves(now)

    def _tick_timed_moves(self, now: float) -> None:
        """Stop the alt-az pulse moves whose time is up."""
        for axis, move in list(self.timed_moves.items()):
            if now >= move.end:
                self.end_timed_move(axis, move)

    def end_timed_move(self, axis: int, move: TimedMove | None = None) -> None:
        """Stop one timed move (``move``: only if it is still that one, not a newer pulse's). The check
        and the stop are one step under ``timed_lock``, so a pulse started meanwhile is never cut."""
        with self.timed_lock:
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
        self._safety_stop(f"ending an alt-az guide pulse on axis {axis} failed: {failure}")

    def end_all(self) -> None:
        """End every timed move with its own stop command (the last client gone, shutdown)."""
        for axis in list(self.timed_moves):
            self.end_timed_move(axis)

    # -- forgetting (stops) ----------------------------------------------------------------------

    def forget_pulses(self) -> None:
        """Send no more chunks of the client pulses (the mount finishes the chunk it has)."""
        with self._lock:
            self.pulses.clear()

    def forget_timed_moves(self) -> None:
        """The mount took a :Q#, which ended every timed move: stop none of them again."""
        with self._lock:
            self.timed_moves.clear()

    def forget(self) -> None:
        """An abort: its :Q# ends everything, so forget every pulse and timed move. Called after the
        abort bumped the generation, so a pulse being started meanwhile is either forgotten here or
        never registered (:meth:`start` registers it only if the generation is unchanged)."""
        with self._lock:
            self.pulses.clear()
            self.timed_moves.clear()

    # -- the clients' PulseGuide -----------------------------------------------------------------

    def first_chunk_ms(self, duration_ms: int) -> int:
        """The part of a client pulse sent at once: all of it in alt-az (a timed move), else at
        most what the mount takes in one ``:Mg``."""
        return duration_ms if self.mount.state.altaz else min(duration_ms, PULSE_CHUNK_MS)

    def start(self, direction: Direction, duration_ms: int, chunk: int, generation: int | None = None) -> None:
        """Start a client pulse of any length with its first ``chunk`` (:meth:`first_chunk_ms`); the
        supervisor's loop sends the rest (:meth:`tick`). Callers hold the supervisor's ``_start_lock``;
        ``generation``: the one the supervisor admitted it under (None: the one now)."""
        axis = pulse_axis(direction)
        self._ledger.refund(axis, self.mount.monotonic())  # this pulse replaces any offset pulse
        if generation is None:
            generation = self._stops.value
        try:
            end = self.guide_pulse(direction, chunk, guard=self._stops.guard(generation))
        except (MountReplyError, ProtocolError, LinkError, MotionCancelled) as exc:
            if isinstance(exc, MotionCancelled):
                raise InvalidOperation("PulseGuide cancelled: a stop arrived while it was starting") from exc
            raise driver_error("PulseGuide", exc) from exc
        with self._lock:
            if self._stops.value == generation:
                self.pulses[axis] = Pulse(direction, duration_ms - chunk,
                                          end - chunk / 1000.0 + duration_ms / 1000.0, end)

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
            generation = self._stops.value
            try:
                end = self.guide_pulse(pulse.direction, chunk, guard=self._stops.guard(generation))
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
