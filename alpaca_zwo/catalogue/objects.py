"""Find a sky object by name or coordinates, and where the mount must point for it now (issues 25 and 33).

Pure: no server state. Positions come from packages and published catalogues, not tables of our own:
PyEphem (VSOP87 planets, its Moon and Sun, and the apparent-place reduction), OpenNGC's database as
pyongc ships it (``deepsky``: deep-sky objects, Messier, Caldwell and other numbers, common names),
``star_names.csv`` beside this module (the IAU WGSN's named stars: IAU-CSN J2000 places, Vmag, with
Hipparcos proper motions and Bayer/Flamsteed forms, keyed by HIP; ``tools/make_star_names.py``) and
``sky_data.json`` (the chart's Hipparcos stars to V 4.5, found by HIP number and designation;
``tools/make_sky_data.py``). Typed coordinates are read by ``coordinates``, names compared by
``naming``. PyEphem and pyongc are imported on first use only: the Alpaca server starts and serves
without them (tests/web/test_setup_goto.py checks ``sys.modules``).

Apparent places are in the mount's frame, ``EquatorialSystem`` 1 (topocentric, equinox of date):
PyEphem's ``ra``/``dec`` for an observer are apparent topocentric of date (precession, nutation,
aberration, proper motion; parallax for the solar system: the Moon's is about 1°), with the
pressure set to 0 so no refraction enters them.
"""

from __future__ import annotations

import functools
import json
import math
import re
import unicodedata
from collections.abc import Iterable
from dataclasses import dataclass
from datetime import datetime, timedelta, timezone, tzinfo
from typing import Any

from ..sky import zone_at
from . import constellations, coordinates, data_text, deepsky
from .naming import (
    GREEK,
    GREEK_ABBREV,
    LUNAR,
    SIDEREAL,
    SOLAR,
    SkyObject,
    fold,
    name_key,
    with_abbreviations,
)

__all__ = [
    "LUNAR",
    "MAX_QUERY",
    "SIDEREAL",
    "SOLAR",
    "Apparent",
    "Found",
    "ObjectError",
    "QueryError",
    "Site",
    "SiteZone",
    "SkyObject",
    "apparent",
    "ephem_body",
    "find",
    "lookup",
    "search",
    "site_zone",
    "zone_at",
]

MAX_QUERY = 80  # characters: the longest name or coordinate form anyone types
TOO_LONG = (f"That is longer than any name or coordinates ({MAX_QUERY} characters at most): "
            "type a name such as Vega, M31 or Omega Centauri, or coordinates such as 5h35m −5°23′.")

PLANETS = ("Mercury", "Venus", "Mars", "Jupiter", "Saturn", "Uranus", "Neptune")
_BODY_KIND = {"Sun": "star (the Sun)", "Moon": "moon", **{p: "planet" for p in PLANETS}}
SATELLITES = ("iss", "international space station", "tiangong", "css", "hst", "hubble space telescope",
              "starlink", "satellite", "satellites")
SATELLITE_NOTE = ("Satellites cross the sky in minutes and are not in the catalogue: give the satellite's TLE "
                  "on the Satellites card, which lists its passes and follows one (docs/satellites.md).")


class ObjectError(ValueError):
    """An object id or name that names nothing (HTTP 404; the page shows the message)."""


class QueryError(ObjectError):
    """Text that cannot be a query: empty, too long, control characters, impossible or ambiguous
    coordinates (HTTP 400; the message says what to type instead)."""


@dataclass(frozen=True)
class Found:
    """What a search found: (object, the name or designation it matched by, if not its title), best first;
    ``confident`` when the first is surely what was meant (Enter may take it); ``note`` for the person."""

    matches: tuple[tuple[SkyObject, str | None], ...]
    confident: bool
    note: str | None = None

    @property
    def objects(self) -> list[SkyObject]:
        return [obj for obj, _ in self.matches]


@dataclass(frozen=True)
class Site:
    latitude: float  # degrees, north positive
    longitude: float  # degrees, east positive
    elevation: float = 0.0  # metres


@dataclass(frozen=True)
class Apparent:
    """Where an object is for one site and instant, in the mount's frame (topocentric, of date)."""

    ra_hours: float
    dec_deg: float
    altitude: float  # geometric, degrees (no refraction)
    azimuth: float  # degrees from north through east
    rise: datetime | None
    transit: datetime | None
    set: datetime | None
    always_up: bool
    never_up: bool


# -- stars --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _StarIndex:
    by_key: dict[str, SkyObject]  # folded name or designation ("vega", "α lyr", "alpha lyr", "γ cas") -> star
    by_hip: dict[int, SkyObject]
    names: frozenset[str]  # the keys that are names, not designations


@functools.lru_cache(maxsize=1)
def _star_index() -> _StarIndex:
    """The IAU-named stars (``star_names.csv``, with PyEphem's other names for them: "Agena", "Alcaid"),
    then the chart's unnamed stars to V 4.5 (``sky_data.json``) by Bayer/Flamsteed designation and HIP."""
    by_key: dict[str, SkyObject] = {}
    by_hip: dict[int, SkyObject] = {}
    names: set[str] = set()
    by_place: dict[tuple[float, float], SkyObject] = {}
    table = data_text("star_names.csv")
    for line in table.splitlines():
        if not line[:1].isdigit():
            continue
        hip, name, vmag, ra, dec, pm_ra, pm_dec, designations = line.split(",", 7)
        aliases = tuple(d for d in designations.split(";") if d)
        obj = SkyObject(f"star:{name}", name, "star", float(vmag), float(ra) / 15.0, float(dec),
                        aliases=(*aliases, f"HIP {hip}"), pm_ra_mas=float(pm_ra), pm_dec_mas=float(pm_dec))
        names.add(fold(name))
        _index(by_key, obj, (name, *aliases))
        by_hip.setdefault(int(hip), obj)
        by_place[round(float(ra), 3), round(float(dec), 3)] = obj
    for key, obj in _ephem_star_names(by_place).items():
        by_key.setdefault(key, obj)
        names.add(key)
    for hip, ra, dec, vmag, _name, designations, pm_ra, pm_dec in _chart_stars():
        if hip in by_hip:
            continue
        forms = tuple(d for d in designations.split(";") if d)
        obj = SkyObject(f"hip:{hip}", forms[0] if forms else f"HIP {hip}", "star", vmag, ra / 15.0, dec,
                        aliases=(*forms[1:], f"HIP {hip}"), pm_ra_mas=pm_ra, pm_dec_mas=pm_dec)
        _index(by_key, obj, forms)
        by_hip[hip] = obj
    return _StarIndex(by_key, by_hip, frozenset(names))


def _index(by_key: dict[str, SkyObject], obj: SkyObject, forms: Iterable[str]) -> None:
    """Each form of a star's name as a key; a designation several stars share ("α Cen": Rigil Kentaurus,
    Toliman, Proxima) means the brightest."""
    for form in forms:
        for key in (fold(form), fold(_latin_form(form))):
            held = by_key.get(key)
            if held is None or (_brightness(obj) < _brightness(held) and key != fold(held.name)):
                by_key[key] = obj


def _brightness(obj: SkyObject) -> float:
    return 99.0 if obj.magnitude is None else obj.magnitude


@functools.lru_cache(maxsize=1)
def _chart_stars() -> list[list[Any]]:
    """``sky_data.json``'s stars: [hip, ra°, dec°, vmag, name|null, designations, pm RA, pm Dec]."""
    data = json.loads(data_text("sky_data.json"))
    stars: list[list[Any]] = data["stars"]
    return stars


def _ephem_star_names(by_place: dict[tuple[float, float], SkyObject]) -> dict[str, SkyObject]:
    """PyEphem's traditional names of the IAU-named stars (its list and the IAU's agree to 0.01″)."""
    import ephem.stars

    found: dict[str, SkyObject] = {}
    for name in ephem.stars.stars:
        star = ephem.stars.star(name)
        obj = by_place.get((round(math.degrees(float(star._ra)), 3), round(math.degrees(float(star._dec)), 3)))
        if obj is not None:
            found[fold(name)] = obj
    return found


def _latin_form(designation: str) -> str:
    """"α Lyr" → "alpha Lyr" (the form people type); numbers and Latin letters stay."""
    letter, _, rest = designation.partition(" ")
    base, digits = letter[:1], letter[1:]
    for latin, greek in GREEK.items():
        if base == greek:
            return f"{latin}{digits} {rest}"
    return designation


def _designation_key(query: str) -> str:
    """"alp Lyr", "alpha1 Cru", "Alpha Centauri" → the Greek form the table holds ("α Lyr", "α1 Cru", "α Cen")."""
    folded = with_abbreviations(fold(query))
    m = re.fullmatch(r"([a-z]+)(\d?)\s+([a-z]{3})", folded)
    if not m:
        return folded
    word, digit, con = m.groups()
    letter = GREEK.get(word) or GREEK_ABBREV.get(word)
    return fold(f"{letter}{digit} {con}") if letter else folded


def _star(query: str) -> tuple[SkyObject, str] | None:
    """The star a name, designation ("alpha Cen", "Alpha Centauri", "γ Cas") or "HIP 91262" names."""
    stars = _star_index()
    m = re.fullmatch(r"hip\s*(\d{1,6})", fold(query))
    if m:
        found = stars.by_hip.get(int(m.group(1)))
        return (found, f"HIP {int(m.group(1))}") if found else None
    for key in (_designation_key(query), fold(query)):
        obj = stars.by_key.get(key)
        if obj is not None:  # matched by a designation it carries ("α Cen"), or by another name ("Agena")
            written = [a for a in (obj.name, *obj.aliases) if key in (fold(a), fold(_latin_form(a)))]
            return obj, written[0] if written else query.strip()
    return None


def _star_prefixes(folded: str, exclude: SkyObject | None) -> list[tuple[SkyObject, str | None]]:
    """Stars whose name begins so; designations only once a space shows one is meant ("alpha L"): "Al" is Altair."""
    stars = _star_index()
    found: dict[str, SkyObject] = {}
    for key, obj in stars.by_key.items():
        if key.startswith(folded) and obj is not exclude and (" " in folded or key in stars.names):
            found.setdefault(obj.id, obj)
    return [(o, None) for o in sorted(found.values(), key=_brightness)]


# -- search and lookup ---------------------------------------------------------------------------------


def search(query: str, limit: int = 8) -> list[SkyObject]:
    """The matches for what someone typed, best first (:func:`find` without the notes)."""
    return find(query, limit).objects


def find(query: str, limit: int = 8) -> Found:
    """The matches for what someone typed, best first: exact names and designations, then names that begin
    so, then names whose words begin so; typed coordinates (both readings when ambiguous)."""
    text = query.strip()
    if not text:
        raise QueryError("type a name or coordinates")
    if len(text) > MAX_QUERY:
        raise QueryError(TOO_LONG)
    if any(unicodedata.category(c)[0] == "C" for c in text):
        raise QueryError("type a name or coordinates (letters, digits and signs only)")
    try:
        readings = coordinates.parse(text)
    except coordinates.CoordinateError as exc:
        raise QueryError(str(exc)) from None
    if readings is not None:
        return _coordinates_found(text, readings)
    return _names_found(text, limit)


def _coordinates_found(text: str, readings: list[coordinates.CoordinateReading]) -> Found:
    found = tuple((_coordinate_object(r.ra_hours, r.dec_deg, r.ra_unit if r.ambiguous else None), None)
                  for r in readings)
    if len(found) == 1:
        return Found(found, confident=True)
    number = re.search(r"\d+(?:\.\d*)?", text)
    first = number.group() if number else "the RA"
    return Found(found, confident=False, note=(
        f"Is {first} the RA in hours or in degrees? Choose one below, or type {first}h or {first}° to say which."))


def _names_found(text: str, limit: int) -> Found:
    folded = fold(text)
    key = name_key(text)
    exact: list[tuple[SkyObject, str | None]] = []
    body = next((b for b in _BODY_KIND if fold(b) == key), None)
    if body:
        exact.append((_body(body), None))
    star = _star(text)
    if star:
        exact.append((star[0], None if fold(star[1]) == fold(star[0].name) else star[1]))
    dso = deepsky.by_designation(text)
    if dso:
        exact.append((dso, None if fold(dso.name) == folded else text.strip()))
    named = deepsky.by_common_name(key) if key else {"exact": [], "prefix": [], "words": []}
    exact += _as_matched(named["exact"])
    prefix: list[tuple[SkyObject, str | None]] = [(_body(b), None) for b in _BODY_KIND
                                                   if key and fold(b).startswith(key) and b != body]
    prefix += _star_prefixes(folded, star[0] if star else None) if folded else []
    prefix += _by_magnitude(_as_matched(named["prefix"]))
    words = _by_magnitude(_as_matched(named["words"])) if len(key) >= 3 else []
    first: dict[str, tuple[SkyObject, str | None]] = {}
    for obj, how in exact + prefix + words:
        first.setdefault(obj.id, (obj, how))
    objects_found = tuple(first.values())
    figure = constellations.by_key(key) if key else None
    distinct_exact = {obj.id for obj, _ in exact}
    confident = (len(distinct_exact) == 1 or (not exact and len(objects_found) == 1 and len(key) >= 3)
                 or (not objects_found and figure is not None))
    if figure is None:
        return Found(objects_found[:limit], confident, _note(text, key, objects_found[:limit], confident))
    # A constellation named exactly ("Leo", "Crux", "Southern Cross") is the one meant, before the objects its
    # name merely begins ("Leo I", a faint dwarf galaxy) or is a word of ("Small Sagittarius Star Cloud"),
    # except an object named so exactly and a famous one whose name begins so ("Andromeda" is first the galaxy).
    constellation = (figure[0], None if figure[1] == figure[0].name else figure[1])
    begun = {obj.id for obj, _ in prefix}
    ahead = [pair for pair in objects_found
             if pair[0].id in distinct_exact or (pair[0].id in begun and _famous(pair[0]))]
    after = [pair for pair in objects_found if pair not in ahead]
    matches = (*ahead, constellation, *after)[:limit]
    confident = confident if ahead else True
    return Found(matches, confident, _note(text, key, matches, confident))


#: A deep-sky object is famous, for the search's order, when it is a Messier or Caldwell object a small
#: telescope shows: no fainter than this (Centaurus A's 7.2 is; Perseus A's 12.2, Caldwell 24, is not).
FAMOUS_MAGNITUDE = 8.0


def _famous(obj: SkyObject) -> bool:
    """A Messier or Caldwell object of magnitude 8 or brighter ("Andromeda Galaxy", "Centaurus A")."""
    listed = any(re.fullmatch(r"[MC]\s?\d+", name) for name in (obj.name, *obj.aliases))
    return listed and obj.magnitude is not None and obj.magnitude <= FAMOUS_MAGNITUDE


def _as_matched(pairs: list[tuple[SkyObject, str]]) -> list[tuple[SkyObject, str | None]]:
    return [(obj, None if how == obj.name else how) for obj, how in pairs]


def _by_magnitude(pairs: list[tuple[SkyObject, str | None]]) -> list[tuple[SkyObject, str | None]]:
    return sorted(pairs, key=lambda p: _brightness(p[0]))


def _note(text: str, key: str, matches: tuple[tuple[SkyObject, str | None], ...], confident: bool) -> str | None:
    if key in SATELLITES or key.startswith("starlink"):
        return SATELLITE_NOTE
    if matches and not confident:
        return f"Several objects match \u201c{text.strip()}\u201d: choose one."
    if matches:
        return None
    shape = deepsky.designation(text)
    if shape is not None or re.fullmatch(r"hip\s*\d+", fold(text)):
        return (f"{text.strip()} is not in the catalogues here (OpenNGC for deep-sky objects, with only Sh2-155 of "
                "the Sharpless list; stars by HIP number to magnitude 4.5 and the IAU-named ones): "
                "type its coordinates instead.")
    return None


def _body(name: str) -> SkyObject:
    return SkyObject(f"body:{name}", name, _BODY_KIND[name], body=name)


def _coordinate_object(ra: float, dec: float, reading: str | None = None) -> SkyObject:
    name = f"RA {_sexagesimal(ra)} Dec {_sexagesimal(dec, signed=True)}"
    kind = "coordinates (J2000)" + (f", RA read as {reading}" if reading else "")
    return SkyObject(f"radec:{ra:.7f},{dec:.6f}", name, kind, None, ra, dec)


def _sexagesimal(value: float, signed: bool = False) -> str:
    sign = "-" if value < 0 else "+" if signed else ""
    total = round(abs(value) * 3600.0)
    return f"{sign}{total // 3600:02d}:{total // 60 % 60:02d}:{total % 60:02d}"


def lookup(object_id: str) -> SkyObject:
    """The object an id from :func:`find` names; any other text is searched and its best match taken
    (never one reading of ambiguous coordinates: that raises :class:`QueryError` saying so)."""
    kind, _, rest = object_id.partition(":")
    found = _by_id(kind, rest)
    if found is not None:
        return found
    result = find(object_id, 1)
    if not result.matches:
        raise ObjectError(result.note or f"nothing called {object_id.strip()!r} in the catalogues")
    if not result.confident and result.matches[0][0].id.startswith("radec:"):
        raise QueryError(f"{object_id.strip()!r}: is the RA in hours or in degrees? Write it with h or °")
    return result.matches[0][0]


def _by_id(kind: str, rest: str) -> SkyObject | None:
    if kind == "body" and rest in _BODY_KIND:
        return _body(rest)
    if kind == "star" and fold(rest) in _star_index().names:
        return _star_index().by_key[fold(rest)]
    if kind == "hip" and rest.isdigit() and len(rest) <= 6:
        return _star_index().by_hip.get(int(rest))
    if kind == "con" and rest.isalpha() and len(rest) <= 3:
        return constellations.by_abbreviation(rest)
    if kind == "dso" and re.fullmatch(r"[A-Za-z0-9 +_.-]{1,40}", rest):
        return deepsky.by_name(rest)
    m = re.fullmatch(r"(\d{1,2}(?:\.\d+)?),([+-]?\d{1,2}(?:\.\d+)?)", rest) if kind == "radec" else None
    if m and 0.0 <= float(m.group(1)) < 24.0 and -90.0 <= float(m.group(2)) <= 90.0:
        return _coordinate_object(float(m.group(1)), float(m.group(2)))
    return None


# -- the site's time zone ------------------------------------------------------------------------------


@dataclass(frozen=True)
class SiteZone:
    """The zone the page gives times in: the site's own, named in the zone database, when its coordinates
    can be looked up; else the server's own when it fits the site's longitude, else the longitude's
    nominal zone (``source`` says which: "site", "server" or "longitude")."""

    zone: tzinfo
    source: str

    def label(self, when: datetime) -> str:
        offset = when.astimezone(self.zone).utcoffset() or timedelta(0)
        minutes = round(offset.total_seconds() / 60)
        sign = "+" if minutes >= 0 else "\u2212"
        text = f"UTC{sign}{abs(minutes) // 60}" + (f":{abs(minutes) % 60:02d}" if minutes % 60 else "")
        name = when.astimezone(self.zone).tzname()
        return f"{name}, {text}" if name and not name.startswith(("UTC", "+", "-")) else text

    @property
    def name(self) -> str | None:
        """The zone database's name ("Australia/Sydney"), when the zone is one of its zones."""
        key = getattr(self.zone, "key", None)
        return key if isinstance(key, str) else None


SERVER_ZONE_SLACK_H = 3.0  # zones reach this far from their longitude's (China's +8 at 75° E: 3 h)


def site_zone(longitude: float, when: datetime, server_zone: tzinfo | None = None,
              latitude: float | None = None) -> SiteZone:
    """The site's zone. Its own (``zone_at``) when the latitude is given and the place can be looked up: a
    server in a UTC container, or a Pi left on another zone, must not move the site's clock. Otherwise a Pi
    at the telescope has its zone set (with daylight saving), so the server's zone when its offset is within
    ``SERVER_ZONE_SLACK_H`` of the longitude's mean solar time; else the longitude's nominal zone,
    UTC + round(longitude / 15) h, with no daylight saving."""
    own = zone_at(latitude, longitude) if latitude is not None else None
    if own is not None:
        return SiteZone(own, "site")
    local = server_zone or datetime.now().astimezone().tzinfo
    assert local is not None
    offset = when.astimezone(local).utcoffset() or timedelta(0)
    if abs(offset.total_seconds() / 3600.0 - longitude / 15.0) <= SERVER_ZONE_SLACK_H:
        return SiteZone(local, "server")
    return SiteZone(timezone(timedelta(hours=round(longitude / 15.0))), "longitude")


# -- apparent place ------------------------------------------------------------------------------------


def observer(site: Site, when: datetime) -> Any:
    import ephem

    obs = ephem.Observer()
    obs.lat, obs.lon = math.radians(site.latitude), math.radians(site.longitude)
    obs.elevation = site.elevation
    obs.date = ephem.Date(when.astimezone(timezone.utc).replace(tzinfo=None))
    obs.pressure = 0.0  # geometric: the mount's frame has no refraction
    return obs


def ephem_body(obj: SkyObject) -> Any:
    import ephem

    if obj.body is not None:
        return getattr(ephem, obj.body)()
    assert obj.ra_hours is not None and obj.dec_deg is not None
    fixed = ephem.FixedBody()
    fixed._ra, fixed._dec = math.radians(obj.ra_hours * 15.0), math.radians(obj.dec_deg)
    fixed._pmra, fixed._pmdec = obj.pm_ra_mas, obj.pm_dec_mas  # mas/yr, as PyEphem's own star list
    fixed._epoch = ephem.J2000  # equinox and epoch of the position
    return fixed


def apparent_radec(obj: SkyObject, site: Site, when: datetime) -> tuple[float, float]:
    """Topocentric apparent RA (hours) and Dec (degrees) of date at ``when``, without the rise and set
    searches of :func:`apparent`: cheap enough to sample a day of a moving body's path."""
    target = ephem_body(obj)
    target.compute(observer(site, when))
    return (math.degrees(float(target.ra)) / 15.0) % 24.0, math.degrees(float(target.dec))


def apparent(obj: SkyObject, site: Site, when: datetime) -> Apparent:
    """Topocentric apparent RA/Dec of date, Alt/Az, and the rise/transit/set around ``when``."""
    obs = observer(site, when)
    target = ephem_body(obj)
    target.compute(obs)
    ra_h = math.degrees(float(target.ra)) / 15.0
    return Apparent(ra_h % 24.0, math.degrees(float(target.dec)), math.degrees(float(target.alt)),
                    math.degrees(float(target.az)) % 360.0, *_rise_transit_set(target, obs))


def _rise_transit_set(target: Any, obs: Any) -> tuple[datetime | None, datetime | None, datetime | None, bool, bool]:
    """The next rise, transit and set within a day of the observer's instant (horizon 0°, no refraction)."""
    import ephem

    def when(method: str) -> datetime | None:
        try:
            return ephem.Date(getattr(obs, method)(target)).datetime().replace(tzinfo=timezone.utc)  # type: ignore[no-any-return]
        except (ephem.AlwaysUpError, ephem.NeverUpError):
            return None

    always = never = False
    try:
        obs.next_rising(target)
    except ephem.AlwaysUpError:
        always = True
    except ephem.NeverUpError:
        never = True
    return when("next_rising"), when("next_transit"), when("next_setting"), always, never
