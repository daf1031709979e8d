"""Braking-aware limits: a manual move stops where it would come to rest, not where it is.

The supervisor stops a MoveAxis when the point it would reach if told to stop now (its speed for
the reaction time, then the braking distance at the mount's deceleration) lies below the horizon
profile or the minimum altitude, or past the meridian limit on the normal side of the pier. A mount
already below the horizon profile or the minimum altitude may move any way that does not lower it.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable

from .. import sky
from .._exceptions import (
    InvalidOperation,
)
from ..config.settings import Settings, horizon_altitude_at
from ..mount.operations import Mount
from ..mount.state import MountState
from ..sky import PierSide
from ..zwo.wire_values import MountMode
from .kinds import DECELERATION_DEG_S2, TICK_S, _wrap12

log = logging.getLogger(__name__)

#: Reaction allowance for a limit stop on top of the braking distance, in supervisor ticks.
LIMIT_TICKS = 2.0
#: Altitudes this close count as equal (rounding): a mount under the limit may move this little lower.
CLIMB_TOLERANCE_DEG = 1e-6
#: A mount at the limit (within this of it) may move along it, this far below at most: on the equator
#: home points at the pole on the horizon, where a Dec move follows an hour circle that dips below it by
#: the move times the RA axis' turn from HA ±6 h (ConformU's MoveAxis test from home, after its RA moves
#: and tracking there: 0.02° measured). Half a degree along the horizon: nothing is in the way.
LIMIT_MARGIN_DEG = 0.5


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
    """Degrees past the meridian the normal (W) side may go, or None where there is no meridian limit
    (an alt-az mount has no pier side to flip)."""
    if state.status is not None and state.status.mode is MountMode.ALTAZ:
        return None
    limits = settings.limits
    return sky.flip_line_deg(float(limits.meridian_limit_deg), limits.meridian_track_past)


class Limits:
    """The braking-aware limit rules for manual moves (the module docstring). Owns no state and no
    lock; the supervisor stops the moves these rules condemn (``MotionSupervisor._tick_limits``)."""

    def __init__(self, *, mount: Mount, settings: Callable[[], Settings], lst: Callable[[], float]) -> None:
        self.mount = mount
        self._settings = settings
        self._lst = lst

    def check_move(self, axis: int, rate: float) -> None:
        """Refuse a manual move that would have to stop at once (already at a limit, heading on)."""
        limit = self.reached({axis: rate}, self.mount.state, running=False)
        if limit:
            raise InvalidOperation(f"MoveAxis refused: {limit}")

    def reached(self, moves: dict[int, float], state: MountState, running: bool = True) -> str:
        """Why stopping now would bring the mount to rest beyond a limit ('' if it would not). A move
        already ``running`` has carried the mount on since the last reading, for the reading's age.

        A mount already under the horizon profile or the minimum altitude (home near the equator, a
        limit above the site's latitude, a mount left low by a power cut) may make any motion that
        does not lower its altitude, so it can climb out; one that lowers it is refused."""
        position = self.mount.position()
        if position is None or state.position_time is None:
            return ""
        settings = self._settings()
        latitude = settings.site.latitude
        now = self.mount.monotonic()
        age = max(0.0, now - state.position_time) if running else 0.0
        react = age + LIMIT_TICKS * TICK_S * self.mount.clock_rate
        ha0 = sky.hour_angle(self._lst(), position[0])
        dec0 = position[1]
        # Sky velocities: a move is relative to the sky, so HA changes by -rate (RA up) only.
        v_ha_deg = -moves.get(0, 0.0)
        v_dec = moves.get(1, 0.0)
        altitude0, azimuth0 = sky.equatorial_to_horizontal(ha0, dec0, latitude)
        floor0 = horizon_altitude_at(settings.limits, azimuth0)
        below = altitude0 < floor0 - LIMIT_MARGIN_DEG  # under it: may climb out
        at_limit = abs(altitude0 - floor0) <= LIMIT_MARGIN_DEG  # on it: may move along it
        flip_deg = _flip_limit(settings, state)
        # The meridian limit is the mount's: it applies to the hour angle its axes point at.
        ha_shift = sky.wrap_hours_12(self.mount.mechanical_hour_angle(*position) - ha0)
        for fraction in (0.0, 0.25, 0.5, 0.75, 1.0):
            ha_deg = ha0 * 15.0 + _travel(v_ha_deg, react) * fraction
            dec = dec0 + _travel(v_dec, react) * fraction
            ha, dec = _normalise(ha_deg / 15.0, dec)
            altitude, azimuth = sky.equatorial_to_horizontal(ha, dec, latitude)
            floor = horizon_altitude_at(settings.limits, azimuth)
            allowed = altitude >= floor - CLIMB_TOLERANCE_DEG or (
                below and altitude >= altitude0 - CLIMB_TOLERANCE_DEG) or (
                at_limit and altitude >= floor - LIMIT_MARGIN_DEG)
            if not allowed:
                if below or at_limit:
                    return (f"horizon limit: the mount is at altitude {altitude0:.2f}°, at or under the limit, and "
                            f"this motion would lower it to {altitude:.2f}°; only motions that do not lower it are "
                            f"allowed (from here: {self._climbing_directions(ha0, dec0, latitude)})")
                return (f"horizon limit: it would come to rest at altitude {altitude:.2f}°, under the {floor:.2f}° "
                        f"allowed at azimuth {azimuth:.1f}°")
            mount_ha_deg = sky.wrap_hours_12(ha + ha_shift) * 15.0
            if flip_deg is not None and state.side is PierSide.WEST and v_ha_deg > 0 and mount_ha_deg > flip_deg:
                return (f"meridian limit: it would come to rest at hour angle {mount_ha_deg:.2f}°, past the "
                        f"{flip_deg:.2f}° allowed")
        return ""

    @staticmethod
    def _climbing_directions(ha: float, dec: float, latitude: float) -> str:
        """The sky directions (north, south, east, west) that do not lower the altitude from here."""
        step = 0.05  # degrees
        altitude = sky.equatorial_to_horizontal(ha, dec, latitude)[0]
        found = []
        for name, d_ha_deg, d_dec in (("north", 0.0, step), ("south", 0.0, -step),
                                      ("east", -step, 0.0), ("west", step, 0.0)):
            there = sky.equatorial_to_horizontal(*_normalise(ha + d_ha_deg / 15.0, dec + d_dec), latitude)[0]
            if there >= altitude - CLIMB_TOLERANCE_DEG:
                found.append(name)
        return ", ".join(found) if found else "none: GOTO a target above the limit"
