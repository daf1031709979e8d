"""The Telescope's pure target checks: ranges, the limits a GoTo must pass, Alt/Az to RA/Dec.

Functions of their inputs only (the settings, the mount's stored altitude limits and the local sidereal
time the caller reads), so a slew or sync is refused with InvalidValue before anything is sent to the
mount, and the setup page can show the very same verdict before a GoTo (``goto_blocked``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from .. import sky
from .._exceptions import InvalidValue
from ..config.settings import Settings, horizon_altitude_at

#: The mount's own horizon: it refuses a GOTO to a target under it (``e5#``) whatever the server allows
#: (``limits.min_altitude_deg`` may go down to -10°). An altitude computed as exactly 0 (the pole seen from
#: the equator) is on it, not under it: rounding is allowed this much.
MOUNT_HORIZON_DEG = 0.0
HORIZON_ROUNDING_DEG = 1e-6

#: The limits a verdict can name (``Blocked.limit``).
HORIZON = "horizon"  # the server's horizon profile
MIN_ALTITUDE = "minimum altitude"  # the server's minimum altitude
MOUNT_HORIZON = "mount horizon"  # e5#
MOUNT_LOWER = "mount altitude limit"  # e6#, zwo:AltitudeLimits "lower"
MOUNT_UPPER = "mount upper altitude limit"  # e6#, zwo:AltitudeLimits "upper"


@dataclass(frozen=True)
class MountAltitudeLimits:
    """The altitude limits stored in the mount (``zwo:AltitudeLimits``, :GLL#/:GLH#), when switched on
    (:GLC#): the mount refuses a GOTO to a target outside them (``e6#``)."""

    lower: float
    upper: float


@dataclass(frozen=True)
class Blocked:
    """Why a GoTo to a target is refused: the limit, in the page's words and in the refusal's."""

    limit: str  # one of the names above
    says: str  # the object card's words: "below the mount's altitude limit of 15°"
    detail: str  # the refusal's message after "target is ": with the altitude and azimuth
    altitude: float  # where the target is when it is out (degrees)
    azimuth: float
    after_s: float  # seconds from now when it is out: 0 now, else while the slew would still run

    @property
    def floor(self) -> bool:
        """The target is under the allowed sky (every limit but the mount's upper one): it must rise first."""
        return self.limit != MOUNT_UPPER


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


def _server_floor(settings: Settings, altitude: float, azimuth: float) -> Blocked | None:
    limits = settings.limits
    floor = horizon_altitude_at(limits, azimuth)
    if altitude >= floor:
        return None
    if floor > limits.min_altitude_deg:
        limit, says = HORIZON, f"below the horizon ({floor:.1f}° there)"
    elif limits.min_altitude_deg == 0.0:
        limit, says = MIN_ALTITUDE, "below the horizon"
    else:
        limit, says = MIN_ALTITUDE, f"below the minimum altitude of {limits.min_altitude_deg:g}°"
    return Blocked(limit, says, f"below the horizon limit: altitude {altitude:.2f}° at azimuth {azimuth:.1f}° "
                                f"is under the {floor:.2f}° allowed there", altitude, azimuth, 0.0)


def _blocked_at(settings: Settings, mount: MountAltitudeLimits | None, lst: float, ra: float, dec: float,
                after_s: float) -> Blocked | None:
    """The limit the target is outside at sidereal time ``lst``: of the floors it is under, the highest
    (the one a person must wait for), else the mount's upper limit."""
    altitude, azimuth = sky.equatorial_to_horizontal(sky.hour_angle(lst, ra), dec, settings.site.latitude)
    where = f"altitude {altitude:.2f}° at azimuth {azimuth:.1f}°"
    found: list[tuple[float, Blocked]] = []
    server = _server_floor(settings, altitude, azimuth)
    if server is not None:
        found.append((horizon_altitude_at(settings.limits, azimuth), server))
    if altitude < MOUNT_HORIZON_DEG - HORIZON_ROUNDING_DEG:
        found.append((MOUNT_HORIZON_DEG, Blocked(
            MOUNT_HORIZON, "below the mount's horizon (0°)",
            f"below the mount's horizon: {where}; the mount refuses any target under 0°", altitude, azimuth, 0.0)))
    if mount is not None and altitude < mount.lower:
        found.append((mount.lower, Blocked(
            MOUNT_LOWER, f"below the mount's altitude limit of {mount.lower:g}°",
            f"below the mount's altitude limit of {mount.lower:g}° (zwo:AltitudeLimits): {where}",
            altitude, azimuth, 0.0)))
    if found:
        blocked = max(found, key=lambda pair: pair[0])[1]
    elif mount is not None and altitude > mount.upper:
        blocked = Blocked(MOUNT_UPPER, f"above the mount's upper altitude limit of {mount.upper:g}°",
                          f"above the mount's upper altitude limit of {mount.upper:g}° (zwo:AltitudeLimits): {where}",
                          altitude, azimuth, 0.0)
    else:
        return None
    if after_s <= 0.0:
        return blocked
    verb = "sinks" if blocked.floor else "climbs"
    lands = f"before the slew lands (in about {math.ceil(after_s)} s)"
    return Blocked(blocked.limit, f"{verb} {blocked.says} {lands}", f"{blocked.detail} {lands}",
                   altitude, azimuth, after_s)


def goto_blocked(settings: Settings, mount: MountAltitudeLimits | None, lst: float, ra: float, dec: float,
                 slew_s: float = 0.0) -> Blocked | None:
    """The one limit check of a GoTo to a sky position (``None``: reachable), what the page shows before one.

    The target must be within every limit when the GoTo is sent, where the mount checks it (its horizon,
    ``e5#``, and its stored altitude limits, ``e6#``), and still be when the slew lands ``slew_s`` seconds
    later (and half-way: an upper limit can be crossed at culmination in between): the server's horizon
    profile and minimum altitude, the mount's horizon and the mount's stored altitude limits (``mount``,
    None when they are off or not known). The meridian limit never refuses a GoTo: the mount takes the
    side its flip rule gives (``sky.goto_pier_side``, docs/meridian.md).
    """
    for after_s in dict.fromkeys((0.0, slew_s / 2.0, slew_s)):
        blocked = _blocked_at(settings, mount, lst + after_s * sky.SIDEREAL_HOURS_PER_S, ra, dec, after_s)
        if blocked is not None:
            return blocked
    return None


def check_goto(settings: Settings, mount: MountAltitudeLimits | None, lst: float, ra: float, dec: float,
               slew_s: float = 0.0) -> None:
    """Refuse a target :func:`goto_blocked` blocks, before anything is sent to the mount."""
    blocked = goto_blocked(settings, mount, lst, ra, dec, slew_s)
    if blocked is not None:
        raise InvalidValue(f"target is {blocked.detail}")


def radec_from_altaz(settings: Settings, lst: float, azimuth: float, altitude: float) -> tuple[float, float]:
    """The RA/Dec that stands at ``azimuth``/``altitude`` at the site when the sidereal time is ``lst``."""
    ha, dec = sky.horizontal_to_equatorial(altitude, azimuth, settings.site.latitude)
    return sky.ra_from_hour_angle(lst, ha), dec
