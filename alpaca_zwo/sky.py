"""Time and coordinate math shared by the emulator, the mount layer and the Telescope.

Pure functions with no project imports, so the emulator and the server compute sidereal time, hour
angle, Alt/Az and pier side with the very same code: a disagreement between the two would show up
as a phantom pointing error or a wrong DestinationSideOfPier.

Conventions (ASCOM's, not the ZWO protocol's):
- hours for RA, HA and sidereal time; degrees for everything else;
- longitude is EAST-positive (the mount's own east-negative sign is handled in ``zwo/protocol.py``);
- azimuth is measured from north through east, in [0, 360);
- UT1 is taken equal to UTC and TT = UTC + 69.184 s. The error this makes (|UT1-UTC| < 0.9 s) is
  far below the mount's one-second RA resolution, and nothing here needs leap-second tables.

The one exception to "math": ``zone_at``, the civil time zone of a place (tzfpy and the zone database),
here because the mount layer sets the mount's clock in it and the catalogue shows times in it.
"""

from __future__ import annotations

import functools
import math
from datetime import datetime, timedelta, timezone
from enum import IntEnum
from zoneinfo import ZoneInfo, ZoneInfoNotFoundError

__all__ = [
    "J2000_JD",
    "LUNAR_DEG_S",
    "LUNAR_RATE",
    "SIDEREAL_DAY_S",
    "SIDEREAL_DEG_S",
    "SIDEREAL_HOURS_PER_S",
    "SOLAR_DEG_S",
    "SOLAR_RATE",
    "SOLAR_SECONDS_PER_SIDEREAL_SECOND",
    "TT_MINUS_UTC_S",
    "PierSide",
    "angular_separation",
    "equatorial_to_horizontal",
    "flip_line_deg",
    "goto_pier_side",
    "greenwich_mean_sidereal_time",
    "horizontal_to_equatorial",
    "hour_angle",
    "julian_date",
    "kept_goto_side",
    "local_sidereal_time",
    "pointing_state",
    "ra_from_hour_angle",
    "side_limit_deg",
    "wrap_degrees_360",
    "wrap_hours_12",
    "wrap_hours_24",
    "zone_at",
]

J2000_JD = 2451545.0
"""Julian date of the J2000.0 epoch, 2000-01-01 12:00 (taken on the UTC time line here)."""

TT_MINUS_UTC_S = 69.184
"""TT - UTC in seconds since 2017 (37 leap seconds + 32.184 s); only feeds a tiny GMST term."""

SIDEREAL_DAY_S = 86164.0905
"""Length of a mean sidereal day in SI seconds: the one home of the sidereal rate."""

SIDEREAL_DEG_S = 360.0 / SIDEREAL_DAY_S
"""Hour-angle rate of a fixed star, degrees per second (15.041 arcsec/s): "1x sidereal" for motion rates."""

SIDEREAL_HOURS_PER_S = 24.0 / SIDEREAL_DAY_S
"""Sidereal hours that pass in one SI second."""

SOLAR_SECONDS_PER_SIDEREAL_SECOND = SIDEREAL_DAY_S / 86400.0
"""0.99727: an hour of hour angle takes this many solar hours while tracking at the sidereal rate."""

SOLAR_RATE = SOLAR_SECONDS_PER_SIDEREAL_SECOND
"""The Sun's tracking rate as a multiple of sidereal (the Sun returns to the meridian every 86400 s)."""

LUNAR_RATE = 1.0 - 1.0 / 27.321661 * SOLAR_SECONDS_PER_SIDEREAL_SECOND
"""The Moon's mean tracking rate as a multiple of sidereal (it moves east once per 27.32-day sidereal month)."""

SOLAR_DEG_S = 360.0 / 86400.0
"""The mean Sun's hour-angle rate, degrees per second (15.000 arcsec/s)."""

LUNAR_DEG_S = 14.685 / 3600.0
"""ASCOM's ``driveLunar`` rate, degrees per second, which the emulator's lunar tracking follows.

Not the same number as ``LUNAR_RATE * SIDEREAL_DEG_S`` (14.49 arcsec/s, the Moon's mean motion):
the two are kept apart as they were, so neither the estimator nor the emulator changes behaviour.
"""

_J2000 = datetime(2000, 1, 1, 12, 0, 0, tzinfo=timezone.utc)
_SECONDS_PER_DAY = 86400.0
_DAYS_PER_CENTURY = 36525.0
_ARCSEC_TO_HOURS = 1.0 / 54000.0  # 15 arcsec of angle per second of time, 3600 s per hour


# --- wrapping -------------------------------------------------------------------------------------
# math.fmod is exact, unlike `x % m` whose result can round up to m itself for tiny negative x; the
# explicit fix-ups below keep every result strictly inside its half-open interval.


def wrap_hours_24(hours: float) -> float:
    """Wrap an angle in hours into [0, 24)."""
    r = math.fmod(hours, 24.0)
    if r < 0.0:
        r += 24.0
        if r >= 24.0:  # -1e-17 + 24 rounds to 24; the same angle is 0
            r = 0.0
    return r


def wrap_hours_12(hours: float) -> float:
    """Wrap an angle in hours into [-12, 12), the range ASCOM uses for hour angles."""
    r = math.fmod(hours, 24.0)
    if r >= 12.0:
        r -= 24.0  # exact (Sterbenz): r and 24 are within a factor of two
    elif r < -12.0:
        r += 24.0
    return r


def wrap_degrees_360(degrees: float) -> float:
    """Wrap an angle in degrees into [0, 360)."""
    r = math.fmod(degrees, 360.0)
    if r < 0.0:
        r += 360.0
        if r >= 360.0:
            r = 0.0
    return r


# --- time -----------------------------------------------------------------------------------------


def _days_since_j2000(t: datetime) -> tuple[int, float]:
    """Split the UTC days since J2000 into whole days and the fraction of a day.

    Kept apart because the Earth rotation angle turns once a day: multiplying a ~9000-day float by
    1.0027 would throw away sub-millisecond precision that the fraction alone keeps.
    """
    if t.utcoffset() is None:
        t = t.replace(tzinfo=timezone.utc)  # naive means UTC, as in the mount's and Alpaca's clocks
    delta: timedelta = t - _J2000  # exact, in whole microseconds
    return delta.days, (delta.seconds + delta.microseconds / 1e6) / _SECONDS_PER_DAY


def julian_date(t: datetime) -> float:
    """Julian date of ``t`` on the UTC time line (a naive datetime is taken as UTC)."""
    days, fraction = _days_since_j2000(t)
    return J2000_JD + days + fraction


def greenwich_mean_sidereal_time(t: datetime) -> float:
    """Greenwich mean sidereal time in hours [0, 24), IAU 2006 model.

    GMST = Earth rotation angle (a linear function of UT1) + a precession polynomial in TT
    centuries. The same model as ``erfa.gmst06``, so the server, the emulator and standard
    astronomy software agree to microseconds, given the UT1 = UTC approximation.
    """
    days, fraction = _days_since_j2000(t)
    ut1_days = days + fraction
    # Earth rotation angle in turns; the whole days drop out except through the 0.0027... term.
    era_turns = math.fmod(fraction + 0.7790572732640 + 0.00273781191135448 * ut1_days, 1.0)
    tc = (ut1_days + TT_MINUS_UTC_S / _SECONDS_PER_DAY) / _DAYS_PER_CENTURY
    precession_arcsec = 0.014506 + tc * (
        4612.156534 + tc * (1.3915817 + tc * (-0.00000044 + tc * (-0.000029956 + tc * -0.0000000368)))
    )
    return wrap_hours_24(era_turns * 24.0 + precession_arcsec * _ARCSEC_TO_HOURS)


def local_sidereal_time(t: datetime, longitude_deg: float) -> float:
    """Local mean sidereal time in hours [0, 24) at an EAST-positive longitude."""
    return wrap_hours_24(greenwich_mean_sidereal_time(t) + longitude_deg / 15.0)


def hour_angle(lst_hours: float, ra_hours: float) -> float:
    """Hour angle in hours [-12, 12): negative east of the meridian (rising), positive west."""
    return wrap_hours_12(lst_hours - ra_hours)


def ra_from_hour_angle(lst_hours: float, ha_hours: float) -> float:
    """Right ascension in hours [0, 24) of the point at ``ha_hours`` when the LST is ``lst_hours``."""
    return wrap_hours_24(lst_hours - ha_hours)


# --- equatorial <-> horizontal --------------------------------------------------------------------
# Both directions are the same rotation about the east-west axis by (90 deg - latitude), written as
# vectors and finished with atan2, which stays accurate at the zenith, the poles and the horizon
# where the textbook asin/acos forms lose digits.


def _cos_sin(degrees: float) -> tuple[float, float]:
    """(cos, sin) of an angle in degrees, exact at multiples of 90°: at a pole (Dec ±90) or on the
    equator's horizon, the rotation must give exactly 0, not the 6e-17 of cos(radians(90)), or a
    mount at home on the equator reads an altitude of -0.0000000000001° (ConformU: "below 0")."""
    quarter, rest = divmod(degrees, 90.0)
    if rest == 0.0:
        return ((1.0, 0.0), (0.0, 1.0), (-1.0, 0.0), (0.0, -1.0))[int(quarter) % 4]
    radians = math.radians(degrees)
    return math.cos(radians), math.sin(radians)


def _rotate(lon_deg: float, lat_deg: float, phi_deg: float) -> tuple[float, float]:
    """Swap between (HA, Dec) and (Az, Alt) frames; the rotation is its own inverse in this form."""
    cos_lon, sin_lon = _cos_sin(lon_deg)
    cos_lat, sin_lat = _cos_sin(lat_deg)
    cos_phi, sin_phi = _cos_sin(phi_deg)
    x = -cos_lon * cos_lat * sin_phi + sin_lat * cos_phi
    y = -sin_lon * cos_lat
    z = cos_lon * cos_lat * cos_phi + sin_lat * sin_phi
    return math.atan2(y, x), math.atan2(z, math.hypot(x, y))


def equatorial_to_horizontal(ha_hours: float, dec_deg: float, latitude_deg: float) -> tuple[float, float]:
    """(altitude, azimuth) in degrees, geometric (no refraction), azimuth N->E in [0, 360).

    At the zenith the azimuth is undefined and whatever atan2 yields is returned.
    """
    az, alt = _rotate(ha_hours * 15.0, dec_deg, latitude_deg)
    return math.degrees(alt), wrap_degrees_360(math.degrees(az))


def horizontal_to_equatorial(
    altitude_deg: float, azimuth_deg: float, latitude_deg: float
) -> tuple[float, float]:
    """(hour angle in hours [-12, 12), declination in degrees) of a geometric Alt/Az position.

    At the celestial poles the hour angle is undefined and whatever atan2 yields is returned.
    """
    ha, dec = _rotate(azimuth_deg, altitude_deg, latitude_deg)
    return wrap_hours_12(math.degrees(ha) / 15.0), math.degrees(dec)


def angular_separation(ra1_hours: float, dec1_deg: float, ra2_hours: float, dec2_deg: float) -> float:
    """Great-circle distance in degrees between two equatorial positions.

    Vincenty's atan2 form: accurate for tiny separations (slew-settled checks compare positions
    arcseconds apart) and for nearly antipodal ones, where acos of a dot product is not.
    """
    d_ra = math.radians((ra2_hours - ra1_hours) * 15.0)
    d1 = math.radians(dec1_deg)
    d2 = math.radians(dec2_deg)
    sin_d1, cos_d1 = math.sin(d1), math.cos(d1)
    sin_d2, cos_d2 = math.sin(d2), math.cos(d2)
    cos_dra = math.cos(d_ra)
    num = math.hypot(cos_d2 * math.sin(d_ra), cos_d1 * sin_d2 - sin_d1 * cos_d2 * cos_dra)
    den = sin_d1 * sin_d2 + cos_d1 * cos_d2 * cos_dra
    return math.degrees(math.atan2(num, den))


# --- pier side ------------------------------------------------------------------------------------


class PierSide(IntEnum):
    """ASCOM PierSide values, which are pointing states rather than physical sides.

    EAST (0) is the "normal" state (counterweight down, looking at the western sky, HA >= 0);
    WEST (1) is "through the pole" (looking at the eastern sky, HA < 0).
    """

    EAST = 0
    WEST = 1
    UNKNOWN = -1


def pointing_state(ha_hours: float) -> PierSide:
    """The ASCOM pointing state for a counterweight-down German mount at ``ha_hours``.

    HA (wrapped into [-12, 12)) < 0 gives WEST, >= 0 gives EAST; a non-finite HA gives UNKNOWN.
    ConformU checks exactly this: SideOfPier at HA -3/-9 is pierWest and at +3/+9 is pierEast.
    """
    if not math.isfinite(ha_hours):
        return PierSide.UNKNOWN
    return PierSide.WEST if wrap_hours_12(ha_hours) < 0.0 else PierSide.EAST


def flip_line_deg(limit_deg: float, track_past: bool) -> float:
    """Where a German mount's flip line lies, in degrees of hour angle past the meridian, for its meridian
    setting (``:STa``: ``limit_deg`` -15..+15 and the "track past" flag): the one rule DestinationSideOfPier,
    the GOTO side, the emulator and the setup page's flip line and countdown all use.

    A negative limit counts whatever the flag says: ZWO's text for ``:STa`` says a negative limit stops
    tracking "n° before the meridian" and the flag only chooses what happens *past* it ("if you choose to
    track, stop according to the limit"; field notes §2.8), so the line is the limit. A positive limit
    moves the line past the meridian only with "track past" on; without it the mount stops at the meridian
    (1° after it), so the line is the meridian. docs/meridian.md, assumption A1.
    """
    return limit_deg if limit_deg < 0.0 or track_past else 0.0


#: Where a ZWO mount stops tracking past the meridian when it may not track past it (ZWO's ``:STa`` text:
#: "if you choose to stop, the stop angle is 1 degree after meridian"; field notes §5.3).
MERIDIAN_STOP_DEG = 1.0


def tracking_stop_deg(limit_deg: float, track_past: bool) -> float:
    """Degrees of hour angle past the meridian at which the mount stops tracking, for its meridian setting:
    a negative limit before the meridian whatever the flag; "track past" on, the limit (1° at least); off,
    1° past. The mount does not flip by itself (ZWO: automatic flip "temporarily not supported"): a GOTO
    after this point is the flip. The emulator's stop and the page's meridian line use this one rule."""
    if limit_deg < 0.0:
        return limit_deg
    return max(limit_deg, MERIDIAN_STOP_DEG) if track_past else MERIDIAN_STOP_DEG


def goto_pier_side(target_ha_hours: float, current_side: PierSide, meridian_limit_deg: float) -> PierSide:
    """The pier side a German mount ends up on after a GOTO to ``target_ha_hours``.

    With L = ``meridian_limit_deg`` / 15 hours (the mount's meridian setting, -15..+15 degrees,
    positive = may track that far past the meridian, negative = must stop that far before it) and
    the target HA wrapped into [-12, 12):

    - HA < min(0, L)        -> WEST (ordinary eastern-sky target);
    - 0 <= HA < L  (L > 0)  -> WEST: the target is just past the meridian but still within the
      distance the mount may track on the west side, so it is reached (or kept) without a flip;
    - L <= HA < 0  (L < 0)  -> EAST: the west side must stop before reaching this HA, so the mount
      already takes the flipped side;
    - HA >= max(0, L)       -> EAST (ordinary western-sky target).

    Put together: WEST if HA < L else EAST, i.e. the flip line is the meridian moved by the limit.
    With L = 0 this equals :func:`pointing_state`.

    The choice depends on the target alone: ``current_side`` is accepted (the mount layer and the
    emulator pass what they know) but deliberately does not change the answer, so that
    DestinationSideOfPier is a pure function of target and settings and ConformU's repeated
    queries never see it depend on where the previous test left the mount. A non-finite HA gives
    UNKNOWN. Raises ValueError for a limit outside -15..+15 degrees (the mount's own range).
    """
    if not -15.0 <= meridian_limit_deg <= 15.0:  # also rejects NaN
        raise ValueError(f"meridian limit {meridian_limit_deg!r} deg is outside -15..+15")
    if not math.isfinite(target_ha_hours):
        return PierSide.UNKNOWN
    return PierSide.WEST if wrap_hours_12(target_ha_hours) < meridian_limit_deg / 15.0 else PierSide.EAST


FLIP_ZONE_DEG = 15.0
"""How far east of the meridian a pierEast pointing may be kept: the mount's own -15° :STa limit
(a negative limit makes the mount take pierEast that far before the meridian). docs/meridian.md."""

FLIP_MARGIN_DEG = 2.0
"""Room a temporary pierWest limit leaves past the target: its HA grows during the slew and landing."""


def side_limit_deg(target_ha_hours: float, side: PierSide) -> int | None:
    """The :STa limit (whole degrees) under which a GOTO to ``target_ha_hours`` lands on ``side``.

    Under the flip line of :func:`goto_pier_side` (WEST below the limit, EAST at or above it):
    EAST needs a limit at or below the HA (0 past the meridian, down to -15° before it), WEST one
    above it with :data:`FLIP_MARGIN_DEG` to spare (0 well before the meridian, up to +15° past it,
    which needs "track past"). None when the mount's -15..+15° range cannot reach: that side cannot
    point there. A limit of 0 also makes a mount that flips at the meridian itself (the other reading
    of the evidence, docs/meridian.md) land on EAST past the meridian and on WEST before it.
    """
    if not math.isfinite(target_ha_hours) or side not in (PierSide.EAST, PierSide.WEST):
        return None
    ha_deg = wrap_hours_12(target_ha_hours) * 15.0
    if side is PierSide.EAST:
        if ha_deg >= 0.0:
            return 0
        return math.floor(ha_deg) if ha_deg >= -FLIP_ZONE_DEG else None
    limit = max(0, math.ceil(ha_deg + FLIP_MARGIN_DEG))
    return limit if limit <= 15 else None


def kept_goto_side(target_ha_hours: float, current_side: PierSide, meridian_limit_deg: float) -> PierSide:
    """The pier side a GOTO through this server lands on: the mount's own choice
    (:func:`goto_pier_side`), except that a mount on EAST stays there for targets past the meridian
    but short of the limit, where the mount alone would swing back to WEST. That keeps a SideOfPier
    flip made just past the meridian through the GOTO a client sends next (N.I.N.A. writes
    SideOfPier, then slews to the same target). Not before the meridian: a mount kept on EAST there
    points counterweight-up, and the mount refuses a sync on that side of the meridian (e9), so a
    plate-solve centring after such a GOTO would fail. The server gets it by a temporary :STa limit
    (:func:`side_limit_deg`)."""
    side = goto_pier_side(target_ha_hours, current_side, meridian_limit_deg)
    if side is PierSide.WEST and current_side is PierSide.EAST and math.isfinite(target_ha_hours) \
            and wrap_hours_12(target_ha_hours) >= 0.0:
        return PierSide.EAST
    return side


@functools.lru_cache(maxsize=64)
def zone_at(latitude: float, longitude: float) -> ZoneInfo | None:
    """The zone in force at a place, with its daylight saving rules: the name tzfpy (offline, the timezone
    boundary builder's polygons) gives the coordinates, read from the IANA database by zoneinfo (the tzdata
    package on Windows). At sea tzfpy answers the nautical zone (``Etc/GMT+9``). None where tzfpy is not
    installed (32-bit ARM: no wheel) or knows no zone there: callers then say what stands in."""
    try:
        from tzfpy import get_tz
    except ModuleNotFoundError:
        return None
    name = get_tz(longitude, latitude)
    try:
        return ZoneInfo(name) if name else None
    except (ZoneInfoNotFoundError, ValueError):  # a name this Python's zone database lacks
        return None
