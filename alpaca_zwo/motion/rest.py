"""At rest, judged from readings: the mount's flags drop before its axes stop braking.

A reading is the mount's own coarse position (whole seconds of RA, whole arcseconds). The mount is
at rest when consecutive readings agree in the frame it holds still (RA/Dec while tracking, HA/Dec
when not) to within that resolution, and the braking time predicted from its last speed is over.
"""

from __future__ import annotations

import itertools
import logging
from collections import deque
from collections.abc import Iterable
from dataclasses import dataclass

from ..mount.operations import Mount
from ..mount.state import MountState
from ..sky import SIDEREAL_HOURS_PER_S
from .kinds import MAX_AXIS_DEG_S, Motion, _wrap12

log = logging.getLogger(__name__)

#: Rest: consecutive readings within these of each other in the frame the mount holds still.
REST_RA_S = 1.5  # seconds of RA: the mount prints whole seconds
REST_DEC_ARCSEC = 1.5
REST_READINGS = 3


@dataclass(frozen=True)
class PositionReading:
    t: float
    ra: float
    dec: float
    tracking: bool


def _displacement(a: PositionReading, b: PositionReading) -> tuple[float, float]:
    """Movement between readings in degrees, in the frame the mount holds still when at rest."""
    dt = b.t - a.t
    d_ra_h = _wrap12(b.ra - a.ra)
    if not b.tracking:
        d_ra_h -= SIDEREAL_HOURS_PER_S * dt  # an idle mount keeps its hour angle: RA grows with LST
    return d_ra_h * 15.0, b.dec - a.dec


def _stable(a: PositionReading, b: PositionReading) -> bool:
    d_ra_deg, d_dec = _displacement(a, b)
    return abs(d_ra_deg) <= REST_RA_S * 15.0 / 3600.0 and abs(d_dec) <= REST_DEC_ARCSEC / 3600.0


class RestDetector:
    """Keeps the recent readings and decides rest.

    Owns ``readings`` (the last 8, appended by the supervisor loop); no lock: a stop reads the
    last two for its braking estimate while the loop may append (a deque's single operations are atomic)."""

    def __init__(self, *, mount: Mount) -> None:
        self.mount = mount
        self.readings: deque[PositionReading] = deque(maxlen=8)

    def record(self, state: MountState) -> None:
        """Keep the newest reading of ``state``, if it is new."""
        if state.raw_ra is None or state.raw_dec is None or state.position_time is None:
            return
        if self.readings and self.readings[-1].t >= state.position_time:
            return
        tracking = bool(state.tracking and state.tracking.on)
        self.readings.append(PositionReading(state.position_time, state.raw_ra, state.raw_dec, tracking))

    def at_rest(self, motion: Motion, now: float) -> bool:
        """Readings after ``rest_from`` stable in the frame the mount holds still, and the
        predicted braking time over. Asks for fresh readings while it waits."""
        if now < motion.rest_from + motion.brake_s:
            self.mount.refresh()
            return False
        recent = [r for r in self.readings if r.t > motion.rest_from]
        if len(recent) < REST_READINGS:
            self.mount.refresh()
            return False
        last = recent[-REST_READINGS:]
        if all(_stable(a, b) for a, b in itertools.pairwise(last)):
            return True
        self.mount.refresh()
        return False

    def speed_estimate(self, rates: Iterable[float]) -> float:
        """Fastest axis speed (deg/s) seen in the last two readings, or of the manual moves' ``rates``."""
        speeds = [abs(rate) for rate in rates]
        if len(self.readings) >= 2:
            a, b = self.readings[-2], self.readings[-1]
            dt = b.t - a.t
            if dt > 0:
                d_ra, d_dec = _displacement(a, b)
                speeds.append(max(abs(d_ra), abs(d_dec)) / dt)
        # Capped: through the pole the RA reading jumps 12 h, which is no speed (it made the braking
        # time of a stop after a slew from home ~4 minutes, and Slewing true all that time).
        return min(max(speeds, default=0.0), MAX_AXIS_DEG_S)
