"""Tracking rate offsets (RightAscensionRate / DeclinationRate) made of guide pulses.

The mount has no command for an offset rate, but it guides: a pulse moves an axis at the guide
rate for a number of milliseconds. An offset is therefore paid as displacement owed: every
``CYCLE_S`` of mount time the owed arcseconds of each axis become one pulse of
``owed / guide speed`` milliseconds, paid half a cycle (and half a pulse) ahead, so the pointing
swings around the ideal path instead of trailing it: a comet at 5″/s is followed to within about
a couple of arcseconds.

Client pulse guiding and offsets share the axes without losing either: while a client pulse runs
on an axis, nothing is sent there and the offset keeps accruing; when an offset pulse is replaced
by a client pulse (the mount runs one pulse per axis), its unfinished part goes back to the owed
balance. Offsets accrue only while the mount tracks and no slew is under way.

An offset larger than ``MAX_DUTY`` of the guide speed (6.8″/s at the default 0.5x guide rate)
cannot be paid in pulses; it runs instead as a slow continuous move at the mount's variable rate
(``:Rv``, steps of 0.01x sidereal = 0.15″/s), which is relative to the sky like tracking itself.
Pulses give 1 ms granularity (0.0075″ at 0.5x); moves 0.15″/s. The largest offset is
``MAX_OFFSET_ARCSEC`` per second.

In alt-az mode the mount's pulses move nothing, and the host would have to time every pulse's start
and stop (``guiding.py``), each a few milliseconds off at the whole pulse speed. Its moves, though,
run at any 0.01x step (``:Rv``) and change speed on the next ``:M?#``. So in alt-az each offset is one
continuous move whose speed is set once a cycle to the step nearest to the rate plus what is owed
(:meth:`OffsetPayer._modulate`, a sigma-delta modulator): it alternates between the two steps around
the rate, the pointing stays within a step x a cycle (0.08″) of the ideal path, and timing errors
count only at the change of speed (0.15″/s). A client pulse takes the axis over for its length; the
offset keeps accruing and is paid after it.

The ledger (:class:`~alpaca_zwo.motion.balance.RateOffsets`) lives in ``balance.py``: MotionSupervisor
owns it and lends it to :class:`OffsetPayer` (here) and to ``guiding.Guiding``.
"""

from __future__ import annotations

import logging
from collections.abc import Callable

from .._exceptions import LinkError, MotionCancelled, MountReplyError, ProtocolError
from ..mount.operations import PULSE_CHUNK_MS, Mount
from ..mount.state import MountState
from ..sky import SIDEREAL_DEG_S, SOLAR_SECONDS_PER_SIDEREAL_SECOND
from .balance import CYCLE_S, RateOffsets
from .guiding import Guiding
from .kinds import Generation, direction_sign

log = logging.getLogger(__name__)

#: The largest offset (arcsec/s), paid by a continuous move: a generous bound for comets and
#: satellites of the solar system, far below slewing speeds.
MAX_OFFSET_ARCSEC = 600.0
#: The largest offset, as a fraction of the guide speed.
MAX_DUTY = 0.9

#: The mount's variable-rate step (0.01x sidereal) in arcsec/s.
_RATE_STEP_ARCSEC = 0.01 * SIDEREAL_DEG_S * 3600.0


def by_pulses(rate_arcsec: float, guide_arcsec_s: float) -> bool:
    """Whether an offset is small enough to be paid in guide pulses (else a continuous move)."""
    return abs(rate_arcsec) <= MAX_DUTY * guide_arcsec_s


def guide_speed_arcsec(guide_rate: float) -> float:
    """Arcseconds per second an axis moves at the mount's guide rate (a fraction of sidereal)."""
    return guide_rate * SIDEREAL_DEG_S * 3600.0


def ra_rate_to_arcsec(seconds_per_sidereal_second: float) -> float:
    """ASCOM RightAscensionRate (RA seconds per sidereal second) in arcseconds of RA per SI second."""
    return seconds_per_sidereal_second * 15.0 / SOLAR_SECONDS_PER_SIDEREAL_SECOND


class OffsetPayer:
    """Pays the rate offsets: guide pulses for small ones, a slow move for large (the module docstring).

    Owns no state and no lock. Lent by MotionSupervisor: ``ledger`` (its RateOffsets), ``stops`` (its
    Generation, for guards) and ``moving`` (whether a slew, a stop or a manual move is under way:
    offsets then start afresh). Uses ``guiding`` (the supervisor's Guiding): its pulses, its timed
    moves (an axis running a client pulse belongs to that pulse) and its ``timed_lock``, which a
    speed change of an alt-az offset move and a client's new rate take."""

    def __init__(self, *, mount: Mount, ledger: RateOffsets, guiding: Guiding, stops: Generation,
                 moving: Callable[[], bool]) -> None:
        self.mount = mount
        self._ledger = ledger
        self._guiding = guiding
        self._stops = stops
        self._moving = moving

    def set_rate(self, axis: int, arcsec_per_s: float) -> None:
        """RightAscensionRate / DeclinationRate (arcsec/s of sky; axis 0 + is east).

        Under ``Guiding.timed_lock``, which the alt-az modulator holds while its speed change is on the
        wire: otherwise a client's zeroing (a reset) could land there, the modulator would book the speed
        it had just set over it, a slew's stop would end that move unbooked, and the next offset would be
        charged for the whole slew (a ConformU run: +0.05″/s measured as 69″/s)."""
        with self._guiding.timed_lock:
            self._ledger.set_rate(axis, arcsec_per_s)

    def tick(self, now: float, state: MountState) -> None:
        """Pay the rate offsets: guide pulses for small ones, a slow move for large (see offsets.py)."""
        offsets = self._ledger
        # An axis running an alt-az pulse (a timed move, guiding.py) belongs to that pulse until it ends.
        own = [axis for axis in (0, 1) if axis not in self._guiding.timed_moves]
        drifting = any(self.mount.drift_rates[axis] for axis in own)
        if not offsets.active and not drifting:
            offsets.reset()  # no offset, no move: nothing booked may outlive them
            return
        tracking = bool(state.tracking and state.tracking.on)
        if self._moving() or not tracking or not offsets.active:
            offsets.reset()  # a slew or a stop starts the offset path afresh from where it ends
            if drifting and not self._moving():
                for axis in own:
                    self._drift(axis, 0.0)
            return
        if state.altaz:
            self._tick_altaz(now, own)
            return
        guide = guide_speed_arcsec(state.guide_rate)
        for axis in own:
            rate = offsets.axes[axis].rate
            wanted = 0.0 if by_pulses(rate, guide) else rate / 3600.0
            if abs(wanted - self.mount.drift_rates[axis]) > 0.01 * SIDEREAL_DEG_S:
                self._drift(axis, wanted)
        if offsets.due(now):
            offsets.accrue(now)
            self._pay(now, guide)

    def _pay(self, now: float, guide: float) -> None:
        """One cycle: the owed displacement of each pulse-paid axis becomes a guide pulse."""
        offsets = self._ledger
        generation = self._stops.value
        for axis in (0, 1):
            if not by_pulses(offsets.axes[axis].rate, guide):
                offsets.axes[axis].owed = 0.0  # paid by the move
                continue
            if axis in self._guiding.pulses or offsets.axes[axis].pulse_end > now:
                continue  # a client pulse (or the last offset pulse) is running there
            pulse = offsets.next_pulse(axis, guide)
            if pulse is None:
                continue
            direction, ms = pulse
            try:
                end = self._guiding.guide_pulse(direction, min(ms, PULSE_CHUNK_MS),
                                                guard=self._stops.guard(generation))
            except (LinkError, ProtocolError, MountReplyError, MotionCancelled) as exc:
                log.debug("rate offset pulse not sent: %s", exc)
                offsets.axes[axis].owed += ms / 1000.0 * guide * direction_sign(direction)
                continue
            offsets.sent(axis, now, end, ms, direction, guide)

    def _tick_altaz(self, now: float, own: list[int]) -> None:
        """Alt-az: once a cycle, set each free axis's offset move for the next cycle."""
        if self._ledger.due(now):
            self._ledger.accrue(now)
            for axis in own:
                if axis not in self._guiding.pulses:
                    self._modulate(axis, now)

    def _modulate(self, axis: int, now: float) -> None:
        """Alt-az: run the axis's offset move for the next cycle at the 0.01x step nearest to the rate
        plus what is owed (paid over the cycle). The speed so alternates between the two steps around
        the rate (a sigma-delta modulator): the pointing stays within a step x a cycle (0.08″) of the
        ideal path, and a command's timing error counts only at the change of speed (0.15″/s), not at
        the whole speed as it would for a pulse that starts and stops."""
        offset = self._ledger.axes[axis]
        with self._guiding.timed_lock:
            if axis in self._guiding.timed_moves:
                return  # a client pulse has the axis
            offset.book_drift(now)
            wanted = offset.rate + offset.owed / CYCLE_S
            wanted = max(-MAX_OFFSET_ARCSEC, min(MAX_OFFSET_ARCSEC, wanted))
            steps = round(abs(wanted) / _RATE_STEP_ARCSEC) * (1 if wanted > 0 else -1)
            if steps == round(offset.drift_speed / _RATE_STEP_ARCSEC):
                return  # already running at that step
            written = self._drift(axis, wanted / 3600.0, exact_start=False)
            if written is None:
                return  # unchanged: the old speed still runs
            offset.book_drift(written)  # the old speed ran until the change was written
            offset.drift_speed = self.mount.drift_rates[axis] * 3600.0

    def _drift(self, axis: int, rate_deg_s: float, exact_start: bool = True) -> float | None:
        """Set an offset move (Mount.drift); when its command was written (mount time), or None if not."""
        try:
            return self.mount.drift(axis, rate_deg_s, guard=self._stops.guard(), exact_start=exact_start)
        except (LinkError, ProtocolError, MountReplyError, MotionCancelled) as exc:
            log.warning("rate offset move on axis %d not changed: %s", axis, exc)
            return None
