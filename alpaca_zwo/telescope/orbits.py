"""Satellites from two-line elements: parsing TLE sets and where a satellite stands for the site (issue 41).

The orbital mechanics are the ``sgp4`` package's (Vallado's SGP4, the reference implementation); this
module writes none of its own. It only turns SGP4's answer into the mount's frame:

* SGP4 gives the satellite's position in TEME, the frame of the true equator and the *mean* equinox of
  date. The site's position is rotated into the same frame by the Greenwich mean sidereal time
  (``sky.greenwich_mean_sidereal_time``, the one the server and the emulator use), and the difference
  of the two vectors is the topocentric direction.
* Right ascension in TEME minus the server's local *mean* sidereal time is the true hour angle: TEME's
  x axis is the mean equinox, so the equation of the equinoxes (≤ 1.2 s of RA) cancels. The RA this
  module reports is therefore the RA a mount whose sidereal time is the mean one (the server's, the
  emulator's) must be sent to point at the satellite; a mount on apparent sidereal time would differ by
  the equation of the equinoxes, at most 18″. Alt/Az follow from the hour angle and Dec by ``sky``,
  geometric (no refraction), as every other Alt/Az of the server.
* Polar motion (≤ 0.5″) and UT1 − UTC (≤ 0.9 s of Earth rotation: ≤ 14″ at the pole of the sky, far
  less for a satellite's hour angle) are left out; light time (a few milliseconds, ≤ 20″ for the ISS)
  too. docs/satellites.md compares this with Skyfield's full reduction.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from datetime import datetime, timedelta, timezone
from typing import Any

from sgp4.api import Satrec, jday

from .. import sky
from .._exceptions import InvalidValue

#: A set older than this (days between its epoch and now) is flagged: the ISS's predictions drift by
#: kilometres a day as drag changes, so after a few days a pass is seconds late and the mount misses it.
STALE_DAYS = 3.0

#: WGS84, the ellipsoid the site's latitude, longitude and elevation are given on (GPS, maps).
_WGS84_A_KM = 6378.137
_WGS84_F = 1.0 / 298.257223563

_SGP4_ERRORS = {
    1: "mean eccentricity out of range", 2: "mean motion below zero", 3: "perturbed eccentricity out of range",
    4: "semi-latus rectum below zero", 6: "the satellite has decayed",
}


@dataclass(frozen=True)
class Tle:
    """One element set: its name, its two lines and SGP4's record of them."""

    name: str
    line1: str
    line2: str
    satrec: Any = field(compare=False, repr=False)

    @property
    def number(self) -> int:
        """The NORAD catalogue number (25544 for the ISS)."""
        return int(self.satrec.satnum)

    @property
    def epoch(self) -> datetime:
        """The instant the elements describe (UTC)."""
        days = self.satrec.jdsatepoch - 2440587.5 + self.satrec.jdsatepochF  # Julian date -> Unix days
        return datetime(1970, 1, 1, tzinfo=timezone.utc) + timedelta(days=days)

    def age_days(self, now: datetime) -> float:
        """Days from the epoch to ``now`` (negative: elements for a later instant)."""
        return (now - self.epoch).total_seconds() / 86400.0

    def stale(self, now: datetime) -> str | None:
        """The warning a set older than :data:`STALE_DAYS` gets, else None."""
        age = self.age_days(now)
        if abs(age) <= STALE_DAYS:
            return None
        when = "old" if age > 0 else "ahead of the clock"
        return (f"{self.name}: elements {abs(age):.1f} days {when} (epoch {self.epoch:%Y-%m-%d %H:%M} UTC); "
                f"predictions drift with age, load a fresh set")

    @property
    def text(self) -> str:
        """The three lines as a user would paste them."""
        return f"{self.name}\n{self.line1}\n{self.line2}"


def _checksum_ok(line: str) -> bool:
    """The TLE checksum: digits summed, each minus sign counting 1, modulo 10, in column 69."""
    total = sum(int(c) if c.isdigit() else 1 if c == "-" else 0 for c in line[:68])
    return line[68].isdigit() and total % 10 == int(line[68])


def _check_line(line: str, number: str, where: str) -> None:
    if len(line) != 69 or not line.startswith(number + " "):
        raise InvalidValue(f"{where}: a TLE line {number} has 69 characters and starts with '{number} '")
    if not _checksum_ok(line):
        raise InvalidValue(f"{where}: checksum of line {number} does not match (a character was changed)")


def tle_from_lines(name: str, line1: str, line2: str, where: tuple[str, str] = ("TLE", "TLE")) -> Tle:
    """One set from its lines, checked (length, line numbers, checksums, SGP4's own reading); ``where``
    names the two lines in a refusal (the line numbers of a pasted text)."""
    line1, line2 = line1.rstrip(), line2.rstrip()
    _check_line(line1, "1", where[0])
    _check_line(line2, "2", where[1])
    where_ = where[0]
    if line1[2:7] != line2[2:7]:
        raise InvalidValue(f"{where_}: lines 1 and 2 name different satellites ({line1[2:7]} and {line2[2:7]})")
    try:
        satrec = Satrec.twoline2rv(line1, line2)
    except ValueError as exc:
        raise InvalidValue(f"{where_}: SGP4 cannot read the elements: {exc}") from None
    if satrec.error:
        raise InvalidValue(f"{where_}: {_SGP4_ERRORS.get(satrec.error, 'elements SGP4 cannot use')}")
    name = name.strip().removeprefix("0 ").strip() or f"NORAD {int(satrec.satnum)}"
    if len(name) > 60 or not name.isprintable():
        raise InvalidValue(f"{where_}: the name line is not a satellite's name")
    return Tle(name, line1, line2, satrec)


def parse_tles(text: str) -> list[Tle]:
    """Every set in ``text``: three-line sets (a name, then lines 1 and 2, as CelesTrak writes them) or
    bare two-line ones, blank lines ignored. Raises InvalidValue naming the first bad line."""
    lines = [(n, line.rstrip()) for n, line in enumerate(text.splitlines(), 1) if line.strip()]
    found: list[Tle] = []
    i = 0
    while i < len(lines):
        n, first = lines[i]
        if first.startswith("1 ") and len(first) == 69:
            name, at = "", i
        else:
            name, at = first, i + 1
        if at + 1 >= len(lines):
            raise InvalidValue(f"line {n}: a set needs a line 1 and a line 2 after its name")
        found.append(tle_from_lines(name, lines[at][1], lines[at + 1][1],
                                    (f"line {lines[at][0]}", f"line {lines[at + 1][0]}")))
        i = at + 2
    if not found:
        raise InvalidValue("no TLE set found: paste a name line and the two element lines")
    return found


@dataclass(frozen=True)
class SatellitePlace:
    """Where a satellite stands for the site at one instant, in the mount's frame (module docstring)."""

    when: datetime
    ra_hours: float
    dec_deg: float
    ha_hours: float
    altitude: float  # geometric, degrees
    azimuth: float  # degrees from north through east
    range_km: float


def _site_teme(latitude: float, longitude: float, elevation_m: float, gmst_hours: float) -> tuple[float, ...]:
    """The site's position in TEME (km): WGS84 geodetic to Earth-fixed, turned by the mean sidereal time."""
    lat = math.radians(latitude)
    e2 = _WGS84_F * (2.0 - _WGS84_F)
    n = _WGS84_A_KM / math.sqrt(1.0 - e2 * math.sin(lat) ** 2)
    h = elevation_m / 1000.0
    rho = (n + h) * math.cos(lat)
    z = (n * (1.0 - e2) + h) * math.sin(lat)
    theta = math.radians(gmst_hours * 15.0 + longitude)
    return rho * math.cos(theta), rho * math.sin(theta), z


def place(tle: Tle, latitude: float, longitude: float, elevation_m: float, when: datetime) -> SatellitePlace:
    """Where ``tle``'s satellite stands for the site at ``when`` (aware or naive UTC)."""
    utc = when if when.tzinfo is not None else when.replace(tzinfo=timezone.utc)
    utc = utc.astimezone(timezone.utc)
    jd, fraction = jday(utc.year, utc.month, utc.day, utc.hour, utc.minute, utc.second + utc.microsecond / 1e6)
    error, position, _velocity = tle.satrec.sgp4(jd, fraction)
    if error:
        raise InvalidValue(f"{tle.name}: SGP4 cannot place it at {utc:%Y-%m-%d %H:%M} UTC: "
                           f"{_SGP4_ERRORS.get(error, 'elements out of range')}")
    gmst = sky.greenwich_mean_sidereal_time(utc)
    site = _site_teme(latitude, longitude, elevation_m, gmst)
    dx, dy, dz = (position[i] - site[i] for i in range(3))
    distance = math.sqrt(dx * dx + dy * dy + dz * dz)
    ra = sky.wrap_hours_24(math.degrees(math.atan2(dy, dx)) / 15.0)
    dec = math.degrees(math.asin(dz / distance))
    ha = sky.hour_angle(sky.wrap_hours_24(gmst + longitude / 15.0), ra)
    altitude, azimuth = sky.equatorial_to_horizontal(ha, dec, latitude)
    return SatellitePlace(utc, ra, dec, ha, altitude, azimuth, distance)
