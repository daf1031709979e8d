"""The Telescope's pure target checks: ranges, the horizon limit, Alt/Az to RA/Dec.

Functions of their inputs only (the settings and the local sidereal time the caller reads), so a
slew or sync is refused with InvalidValue before anything is sent to the mount.
"""

from __future__ import annotations

import math

from .. import sky
from .._exceptions import InvalidValue
from ..config.settings import Settings, horizon_altitude_at


def check_equatorial(ra: float, dec: float) -> None:
    if not (math.isfinite(ra) and 0.0 <= ra < 24.0):
        raise InvalidValue(f"RightAscension {ra} is outside 0..24 hours")
    if not (math.isfinite(dec) and -90.0 <= dec <= 90.0):
        raise InvalidValue(f"Declination {dec} is outside -90..90 degrees")


def check_horizontal(azimuth: float, altitude: float) -> None:
    if not (math.isfinite(azimuth) and 0.0 <= azimuth <= 360.0):
        raise InvalidValue(f"Azimuth {azimuth} is outside 0..360 degrees")
    if not (math.isfinite(altitude) and -90.0 <= altitude <= 90.0):
        raise InvalidValue(f"Altitude {altitude} is outside -90..90 degrees")


def check_above_limits(settings: Settings, lst: float, ra: float, dec: float) -> None:
    """Refuse a target below the configured horizon before anything is sent to the mount."""
    ha = sky.hour_angle(lst, ra)
    altitude, azimuth = sky.equatorial_to_horizontal(ha, dec, settings.site.latitude)
    floor = horizon_altitude_at(settings.limits, azimuth)
    if altitude < floor:
        raise InvalidValue(
            f"target is below the horizon limit: altitude {altitude:.2f}° at azimuth {azimuth:.1f}° "
            f"is under the {floor:.2f}° allowed there"
        )


def radec_from_altaz(settings: Settings, lst: float, azimuth: float, altitude: float) -> tuple[float, float]:
    """The RA/Dec that stands at ``azimuth``/``altitude`` at the site when the sidereal time is ``lst``."""
    ha, dec = sky.horizontal_to_equatorial(altitude, azimuth, settings.site.latitude)
    return sky.ra_from_hour_angle(lst, ha), dec
