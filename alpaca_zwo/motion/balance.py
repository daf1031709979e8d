"""The rate-offset ledger: displacement owed per axis, and the pulses that pay it.

A rate offset (RightAscensionRate / DeclinationRate) accrues owed arcseconds as mount time passes;
:class:`RateOffsets` books what accrues, what each offset pulse or alt-az offset move pays, and
what a client pulse that took an axis over leaves unpaid. It sends nothing: the payer
(``offsets.OffsetPayer``) and the guide pulses (``guiding.Guiding``) do, both lent this one ledger,
which MotionSupervisor owns (and resets on every stop). It has no lock of its own: most writes come
from the supervisor thread; a client's new rate is set, and a client pulse hands an alt-az axis
over, under ``Guiding.timed_lock``; a client pulse refunds under the supervisor's ``_start_lock``;
an abort resets it under the supervisor's ``_lock``. How offsets are paid: ``offsets.py``.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..zwo.wire_values import Direction
from .kinds import direction_sign

#: Mount seconds between offset pulses.
CYCLE_S = 0.5
#: Owed displacement below this many milliseconds of pulse waits for the next cycle.
MIN_PULSE_MS = 5

_DIRECTIONS = ((Direction.EAST, Direction.WEST), (Direction.NORTH, Direction.SOUTH))


@dataclass
class AxisOffset:
    """One axis's offset: its rate, what is owed, and the last pulse or move paying it."""

    rate: float = 0.0  # arcsec/s: + is east (RA up) on axis 0, north on axis 1
    owed: float = 0.0  # arcsec accrued and not yet paid
    pulse_end: float = 0.0  # mount time the last offset pulse ends
    pulse_speed: float = 0.0  # signed arcsec/s of that pulse
    start_delay: float = 0.0  # mount s from deciding a pulse to its start (smoothed): paid that much ahead
    drift_speed: float = 0.0  # alt-az: signed arcsec/s of the offset move running (as the mount runs it)
    drift_since: float = 0.0  # alt-az: mount time up to which that move's displacement is booked

    def book_drift(self, until: float) -> None:
        """Alt-az: count what the offset move paid up to ``until`` (mount time) against the balance."""
        self.owed -= self.drift_speed * (until - self.drift_since)
        self.drift_since = until


@dataclass
class RateOffsets:
    """Owed displacement per axis and when it was last accrued (mount time)."""

    axes: tuple[AxisOffset, AxisOffset] = field(default_factory=lambda: (AxisOffset(), AxisOffset()))
    accrued_at: float | None = None

    @property
    def active(self) -> bool:
        return any(axis.rate != 0.0 for axis in self.axes)

    def set_rate(self, axis: int, arcsec_per_s: float) -> None:
        self.axes[axis].rate = arcsec_per_s
        if not self.active:
            self.reset()

    def reset(self) -> None:
        """Forget what is owed (a slew moved the mount somewhere new, tracking stopped)."""
        for axis in self.axes:
            axis.owed = 0.0
            axis.drift_speed = 0.0
        self.accrued_at = None

    def accrue(self, now: float) -> None:
        if self.accrued_at is not None:
            dt = max(0.0, now - self.accrued_at)
            for axis in self.axes:
                axis.owed += axis.rate * dt
        self.accrued_at = now

    def due(self, now: float) -> bool:
        return self.active and (self.accrued_at is None or now - self.accrued_at >= CYCLE_S)

    def refund(self, index: int, now: float) -> None:
        """A client pulse replaced the offset pulse on this axis: owe its unfinished part again."""
        axis = self.axes[index]
        if axis.pulse_end > now:
            axis.owed += axis.pulse_speed * (axis.pulse_end - now)
            axis.pulse_end = now

    def next_pulse(self, index: int, guide_arcsec_s: float) -> tuple[Direction, int] | None:
        """The pulse that pays what is owed on an axis, plus what accrues until the middle of the next
        cycle (booked as paid, so the balance goes slightly negative), or None."""
        axis = self.axes[index]
        # Half a cycle (and half the pulse) ahead, plus the time a pulse takes to start (its exchange,
        # the other axis's pulse first): then the pointing swings around the ideal path, not behind it.
        lead = CYCLE_S * 0.5 * (1.0 + abs(axis.rate) / guide_arcsec_s) + axis.start_delay
        ms = int(abs(axis.owed + axis.rate * lead) / guide_arcsec_s * 1000.0)
        if ms < MIN_PULSE_MS:
            return None
        positive, negative = _DIRECTIONS[index]
        direction = positive if axis.owed + axis.rate * lead > 0 else negative
        paid = ms / 1000.0 * guide_arcsec_s
        axis.owed -= paid if direction is positive else -paid
        return direction, ms

    def handover(self, index: int, at: float) -> None:
        """Alt-az: a client pulse took over the axis at ``at`` (mount time): the offset move ends there."""
        axis = self.axes[index]
        if axis.drift_speed:
            axis.book_drift(at)
            axis.drift_speed = 0.0

    def sent(self, index: int, decided: float, end: float, ms: int, direction: Direction,
             guide_arcsec_s: float) -> None:
        """A pulse of ``ms`` decided at ``decided`` ends at ``end`` (mount times)."""
        axis = self.axes[index]
        delay = min(CYCLE_S, max(0.0, end - ms / 1000.0 - decided))
        axis.start_delay += (delay - axis.start_delay) * 0.3
        axis.pulse_end = end
        axis.pulse_speed = direction_sign(direction) * guide_arcsec_s if ms else 0.0
