"""Tracking rate offsets (RightAscensionRate / DeclinationRate) made of guide pulses.

The mount has no command for an offset rate, but it guides: a pulse moves an axis at the guide
rate for a number of milliseconds. An offset is therefore paid as displacement owed: every
``CYCLE_S`` of mount time the owed arcseconds of each axis become one pulse of
``owed / guide speed`` milliseconds. Between pulses the pointing lags the ideal path by at most one
cycle's worth of offset, so a comet at 5″/s is followed to within about a couple of arcseconds.

Client pulse guiding and offsets share the axes without losing either: while a client pulse runs
on an axis, nothing is sent there and the offset keeps accruing; when an offset pulse is replaced
by a client pulse (the mount runs one pulse per axis), its unfinished part goes back to the owed
balance. Offsets accrue only while the mount tracks and no slew is under way.

Limits: an offset may be at most ``MAX_DUTY`` of the guide speed (the pulses must leave time to
catch up), which at the default 0.5x guide rate is 6.8″/s; the granularity is one millisecond of
guide pulse (0.0075″ at 0.5x).
"""

from __future__ import annotations

from dataclasses import dataclass, field

from ..protocol import Direction
from ..sky import SIDEREAL_DEG_S

#: Mount seconds between offset pulses.
CYCLE_S = 0.5
#: The largest offset, as a fraction of the guide speed.
MAX_DUTY = 0.9
#: Owed displacement below this many milliseconds of pulse waits for the next cycle.
MIN_PULSE_MS = 5
#: One SI second is this many sidereal seconds: RightAscensionRate is in RA seconds per sidereal second.
SIDEREAL_PER_SI = 1.00273790935

_DIRECTIONS = ((Direction.EAST, Direction.WEST), (Direction.NORTH, Direction.SOUTH))


def guide_speed_arcsec(guide_rate: float) -> float:
    """Arcseconds per second an axis moves at the mount's guide rate (a fraction of sidereal)."""
    return guide_rate * SIDEREAL_DEG_S * 3600.0


def ra_rate_to_arcsec(seconds_per_sidereal_second: float) -> float:
    """ASCOM RightAscensionRate (RA seconds per sidereal second) in arcseconds of RA per SI second."""
    return seconds_per_sidereal_second * 15.0 * SIDEREAL_PER_SI


@dataclass
class AxisOffset:
    rate: float = 0.0  # arcsec/s: + is east (RA up) on axis 0, north on axis 1
    owed: float = 0.0  # arcsec accrued and not yet paid
    pulse_end: float = 0.0  # mount time the last offset pulse ends
    pulse_speed: float = 0.0  # signed arcsec/s of that pulse


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
        """The pulse that pays what is owed on an axis (and books it as paid), or None."""
        axis = self.axes[index]
        ms = int(abs(axis.owed) / guide_arcsec_s * 1000.0)
        if ms < MIN_PULSE_MS:
            return None
        positive, negative = _DIRECTIONS[index]
        direction = positive if axis.owed > 0 else negative
        paid = ms / 1000.0 * guide_arcsec_s
        axis.owed -= paid if axis.owed > 0 else -paid
        return direction, ms

    def sent(self, index: int, end: float, ms: int, direction: Direction, guide_arcsec_s: float) -> None:
        axis = self.axes[index]
        axis.pulse_end = end
        sign = 1.0 if direction in (Direction.EAST, Direction.NORTH) else -1.0
        axis.pulse_speed = sign * guide_arcsec_s if ms else 0.0
