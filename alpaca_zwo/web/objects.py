"""Find a sky object by name or coordinates, and where the mount must point for it now (issue 25).

Pure: no server state. Positions come from packages and published catalogues, not tables of our own:
PyEphem (VSOP87 planets, its Moon and Sun, and the apparent-place reduction), OpenNGC's database as
pyongc ships it (deep-sky objects, Messier numbers, common names), and ``star_names.csv`` beside this
module: the IAU WGSN's named stars (IAU-CSN: J2000 places, Vmag) with Hipparcos proper motions and
Bayer/Flamsteed forms, keyed by HIP (``tools/make_star_names.py`` says where each column comes from).
PyEphem and pyongc are imported on first use only: the Alpaca server starts and serves without them
(tests/web/test_setup_goto.py checks ``sys.modules``).

Apparent places are in the mount's frame, ``EquatorialSystem`` 1 (topocentric, equinox of date):
PyEphem's ``ra``/``dec`` for an observer are apparent topocentric of date (precession, nutation,
aberration, proper motion; parallax for the solar system: the Moon's is about 1°), with the
pressure set to 0 so no refraction enters them.
"""

from __future__ import annotations

import contextlib
import functools
import math
import re
import sqlite3
import unicodedata
from dataclasses import dataclass, field
from datetime import datetime, timezone
from importlib import resources
from pathlib import Path
from typing import Any

MAX_QUERY = 80  # characters: the longest name or coordinate form anyone types
SIDEREAL, LUNAR, SOLAR = 0, 1, 2  # ASCOM DriveRates

PLANETS = ("Mercury", "Venus", "Mars", "Jupiter", "Saturn", "Uranus", "Neptune")
_BODY_KIND = {"Sun": "star (the Sun)", "Moon": "moon", **{p: "planet" for p in PLANETS}}
_GREEK = {
    "alpha": "α", "beta": "β", "gamma": "γ", "delta": "δ", "epsilon": "ε", "zeta": "ζ", "eta": "η",
    "theta": "θ", "iota": "ι", "kappa": "κ", "lambda": "λ", "mu": "μ", "nu": "ν", "xi": "ξ", "omicron": "ο",
    "pi": "π", "rho": "ρ", "sigma": "σ", "tau": "τ", "upsilon": "υ", "phi": "φ", "chi": "χ", "psi": "ψ",
    "omega": "ω",
}
_GREEK_ABBREV = {name[:3]: letter for name, letter in _GREEK.items()}  # "Alp Lyr", the Bright Star Catalogue's
_GREEK_ABBREV.update({"ups": "υ", "omi": "ο", "ome": "ω", "eps": "ε"})
_DSO_KINDS = {
    "*": "star", "**": "double star", "*Ass": "stellar association", "OCl": "open cluster",
    "GCl": "globular cluster", "Cl+N": "cluster with nebula", "G": "galaxy", "GPair": "galaxy pair",
    "GTrpl": "galaxy triplet", "GGroup": "galaxy group", "PN": "planetary nebula", "HII": "emission nebula",
    "DrkN": "dark nebula", "EmN": "emission nebula", "Neb": "nebula", "RfN": "reflection nebula",
    "SNR": "supernova remnant", "Nova": "nova",
}


class ObjectError(ValueError):
    """A query or object id that names nothing (the page shows the message)."""


@dataclass(frozen=True)
class SkyObject:
    """One thing to point at: catalogue place (J2000, degrees/hours) or a solar-system body by name."""

    id: str
    name: str
    kind: str
    magnitude: float | None = None
    ra_hours: float | None = None  # J2000
    dec_deg: float | None = None
    body: str | None = None  # "Moon", "Mars", ...; None for catalogue places
    aliases: tuple[str, ...] = field(default=())
    pm_ra_mas: float = 0.0  # proper motion, mas/yr (RA component times cos Dec), epoch J2000
    pm_dec_mas: float = 0.0

    @property
    def tracking_rate(self) -> int:
        """The ASCOM drive rate that keeps it centred: lunar, solar or sidereal."""
        return LUNAR if self.body == "Moon" else SOLAR if self.body == "Sun" else SIDEREAL

    @property
    def is_sun(self) -> bool:
        return self.body == "Sun"

    def to_json(self) -> dict[str, Any]:
        return {"id": self.id, "name": self.name, "kind": self.kind, "magnitude": self.magnitude,
                "ra_j2000": self.ra_hours, "dec_j2000": self.dec_deg, "body": self.body,
                "aliases": list(self.aliases)}


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


# -- the catalogues, loaded once on first use ------------------------------------------------------


def _fold(text: str) -> str:
    """Case, accents and spacing folded: "Alnaïr " and "alnair" are one key."""
    text = unicodedata.normalize("NFKD", text.casefold())
    return re.sub(r"\s+", " ", "".join(c for c in text if not unicodedata.combining(c))).strip()


@functools.lru_cache(maxsize=1)
def _stars() -> dict[str, SkyObject]:
    """The IAU-named stars (``star_names.csv``) by folded name and designation forms, plus the other
    names PyEphem's star list knows them by ("Agena", "Alcaid"), matched by position."""
    index: dict[str, SkyObject] = {}
    by_place: dict[tuple[float, float], SkyObject] = {}
    table = resources.files(__package__).joinpath("star_names.csv").read_text(encoding="utf-8")
    for line in table.splitlines():
        if not line[:1].isdigit():
            continue
        _hip, name, vmag, ra, dec, pm_ra, pm_dec, designations = line.split(",", 7)
        aliases = tuple(d for d in designations.split(";") if d)
        obj = SkyObject(f"star:{name}", name, "star", float(vmag), float(ra) / 15.0, float(dec), aliases=aliases,
                        pm_ra_mas=float(pm_ra), pm_dec_mas=float(pm_dec))
        for key in (name, *aliases, *(_latin_forms(a) for a in aliases)):
            index.setdefault(_fold(key), obj)
        by_place[round(float(ra), 3), round(float(dec), 3)] = obj
    for key, obj in _ephem_star_names(by_place).items():
        index.setdefault(key, obj)
    return index


def _ephem_star_names(by_place: dict[tuple[float, float], SkyObject]) -> dict[str, SkyObject]:
    """PyEphem's traditional names of the IAU-named stars (its list and the IAU's agree to 0.01″)."""
    import ephem.stars

    found: dict[str, SkyObject] = {}
    for name in ephem.stars.stars:
        star = ephem.stars.star(name)
        obj = by_place.get((round(math.degrees(float(star._ra)), 3), round(math.degrees(float(star._dec)), 3)))
        if obj is not None:
            found[_fold(name)] = obj
    return found


def _latin_forms(designation: str) -> str:
    """"α Lyr" → "alpha Lyr" (the form people type); numbers and Latin letters stay."""
    letter, _, rest = designation.partition(" ")
    base, digits = letter[:1], letter[1:]
    for latin, greek in _GREEK.items():
        if base == greek:
            return f"{latin}{digits} {rest}"
    return designation


def _designation_key(query: str) -> str:
    """"alp Lyr", "alpha1 Cru" → the Greek form the table holds ("α Lyr", "α1 Cru")."""
    m = re.fullmatch(r"([a-z]+)(\d?)\s+([a-z]{3})", _fold(query))
    if not m:
        return _fold(query)
    word, digit, con = m.groups()
    letter = _GREEK.get(word) or _GREEK_ABBREV.get(word)
    return _fold(f"{letter}{digit} {con}") if letter else _fold(query)


@functools.lru_cache(maxsize=1)
def _ongc_path() -> Path:
    """OpenNGC's database as pyongc ships it (read with sqlite3: ``pyongc.ongc`` would load numpy)."""
    return Path(str(resources.files("pyongc").joinpath("ongc.db")))


def _ongc(sql: str, params: tuple[Any, ...]) -> list[tuple[Any, ...]]:
    """Rows of OpenNGC's database; none where pyongc is not installed (32-bit ARM without piwheels)."""
    try:
        path = _ongc_path()
    except ModuleNotFoundError:
        return []
    with contextlib.closing(sqlite3.connect(f"file:{path}?mode=ro", uri=True)) as db:
        return db.execute(sql, params).fetchall()


_DSO_COLUMNS = "name, type, ra, dec, vmag, bmag, messier, commonnames, ngc, ic"


def _dso(row: tuple[Any, ...]) -> SkyObject | None:
    name, kind, ra, dec, vmag, bmag, messier, common, ngc, ic = row
    if kind == "Dup":  # a duplicate entry: the object lives under its NGC/IC name
        target = f"NGC{ngc}" if ngc else f"IC{ic}" if ic else None
        rows = _ongc(f"SELECT {_DSO_COLUMNS} FROM objects WHERE name = ?", (target,)) if target else []
        return _dso(rows[0]) if rows and rows[0][1] != "Dup" else None
    if ra is None or dec is None or kind == "NonEx":
        return None
    label = _pretty_designation(name)
    names = [n for n in (common or "").split(",") if n]
    title = f"M{int(messier)}" if messier else label
    aliases = tuple(dict.fromkeys(a for a in (label, *names) if a != title))
    mag = vmag if vmag is not None else bmag
    return SkyObject(f"dso:{name}", title, _DSO_KINDS.get(kind, kind), mag, math.degrees(ra) / 15.0,
                     math.degrees(dec), aliases=aliases)


def _pretty_designation(name: str) -> str:
    """"NGC0224" → "NGC 224"; OpenNGC's other names stay as they are."""
    m = re.fullmatch(r"(NGC|IC)0*(\d+)(.*)", name)
    return f"{m.group(1)} {m.group(2)}{m.group(3)}" if m else name


def _catalogue_name(query: str) -> tuple[str, str] | None:
    """("NGC", "0224") style keys of "NGC 224", "ngc224", "M 31", "IC434"; None for anything else."""
    m = re.fullmatch(r"(m|messier|ngc|ic)\s*0*(\d{1,4})\s*([a-z]?)", _fold(query))
    if not m:
        return None
    cat, number, suffix = m.groups()
    if cat in ("m", "messier"):
        return "M", f"{int(number):03d}"
    return cat.upper(), f"{int(number):04d}{suffix.upper()}"


def _dso_by_designation(query: str) -> SkyObject | None:
    key = _catalogue_name(query)
    if key is None:
        return None
    cat, number = key
    if cat == "M":
        rows = _ongc(f"SELECT {_DSO_COLUMNS} FROM objects WHERE messier = ? ORDER BY type = 'Dup'", (number,))
    else:
        rows = _ongc(f"SELECT {_DSO_COLUMNS} FROM objects WHERE name = ?", (f"{cat}{number}",))
    for row in rows:
        found = _dso(row)
        if found is not None:
            return found
    return None


def _dso_by_common_name(query: str, limit: int) -> list[SkyObject]:
    folded = _fold(query)
    rows = _ongc(f"SELECT {_DSO_COLUMNS} FROM objects WHERE commonnames LIKE ? LIMIT 50", (f"%{query.strip()}%",))
    found = [o for o in (_dso(r) for r in rows) if o is not None]
    exact = [o for o in found if folded in (_fold(n) for n in (o.name, *o.aliases))]
    rest = sorted((o for o in found if o not in exact), key=lambda o: (o.magnitude is None, o.magnitude or 0.0))
    return list(dict.fromkeys(exact + rest))[:limit]


# -- coordinates -------------------------------------------------------------------------------------

_NUM = r"[+-]?\d+(?:\.\d*)?"
_SEX = re.compile(
    r"^(?P<rh>\d{1,2})(?:h|\s+|:)\s*(?P<rm>\d{1,2})(?:m|\s+|:)\s*(?P<rs>\d{1,2}(?:\.\d*)?)s?\s*,?\s+"
    r"(?P<sign>[+-−]?)(?P<dd>\d{1,2})(?:°|d|\s+|:)\s*(?P<dm>\d{1,2})(?:'|′|m|\s+|:)\s*"
    r"(?P<ds>\d{1,2}(?:\.\d*)?)(?:\"|″|''|s)?$")
_DEC = re.compile(rf"^(?P<ra>{_NUM})\s*(?P<h>h?)\s*,?\s+(?P<dec>{_NUM})\s*°?$")


def parse_coordinates(text: str) -> tuple[float, float] | None:
    """J2000 (RA hours, Dec degrees) from "5h35m17s -5°23'28\"", "05 35 17 -05 23 28", "83.82 -5.39"
    (both in degrees) or "5.5877h -5.39"; None when the text is not coordinates. Out of range raises."""
    text = text.strip().replace("−", "-")
    m = _SEX.match(text)
    if m:
        ra = int(m["rh"]) + int(m["rm"]) / 60.0 + float(m["rs"]) / 3600.0
        dec = int(m["dd"]) + int(m["dm"]) / 60.0 + float(m["ds"]) / 3600.0
        dec = -dec if m["sign"] == "-" else dec
        if int(m["rm"]) >= 60 or float(m["rs"]) >= 60 or int(m["dm"]) >= 60 or float(m["ds"]) >= 60:
            raise ObjectError(f"{text!r}: minutes and seconds must be under 60")
    else:
        m = _DEC.match(text)
        if not m:
            return None
        ra = float(m["ra"]) if m["h"] else float(m["ra"]) / 15.0
        dec = float(m["dec"])
    if not (0.0 <= ra < 24.0 and -90.0 <= dec <= 90.0):
        raise ObjectError(f"{text!r}: RA must be 0..24 h (0..360°) and Dec -90..90°")
    return ra, dec


def _coordinate_object(ra: float, dec: float) -> SkyObject:
    name = f"RA {_sexagesimal(ra)} Dec {_sexagesimal(dec, signed=True)}"
    return SkyObject(f"radec:{ra:.7f},{dec:.6f}", name, "coordinates (J2000)", None, ra, dec)


def _sexagesimal(value: float, signed: bool = False) -> str:
    sign = "-" if value < 0 else "+" if signed else ""
    total = round(abs(value) * 3600.0)
    return f"{sign}{total // 3600:02d}:{total // 60 % 60:02d}:{total % 60:02d}"


# -- search and lookup ---------------------------------------------------------------------------------


def search(query: str, limit: int = 8) -> list[SkyObject]:
    """The matches for what someone typed, best first (exact names, then prefixes, then the rest)."""
    text = query.strip()
    if not text or len(text) > MAX_QUERY or any(unicodedata.category(c)[0] == "C" for c in text):
        raise ObjectError(f"type a name or coordinates (1 to {MAX_QUERY} characters)")
    coords = parse_coordinates(text)
    if coords is not None:
        return [_coordinate_object(*coords)]
    folded = _fold(text)
    exact: list[SkyObject] = []
    body = next((b for b in _BODY_KIND if _fold(b) == folded), None)
    if body:
        exact.append(_body(body))
    star = _stars().get(_designation_key(text)) or _stars().get(folded)
    if star:
        exact.append(star)
    dso = _dso_by_designation(text)
    if dso:
        exact.append(dso)
    prefix = [_body(b) for b in _BODY_KIND if _fold(b).startswith(folded) and b != body]
    # Prefixes of names; of designations only once a space shows one is meant ("alpha L"): "Al" is Altair.
    prefix += sorted({o.id: o for k, o in _stars().items() if k.startswith(folded) and o is not star
                      and (" " in folded or k == _fold(o.name))}.values(),
                     key=lambda o: o.magnitude if o.magnitude is not None else 99.0)
    more = _dso_by_common_name(text, limit) if len(folded) >= 3 else []
    return list({o.id: o for o in exact + prefix + more}.values())[:limit]


def _body(name: str) -> SkyObject:
    return SkyObject(f"body:{name}", name, _BODY_KIND[name], body=name)


def lookup(object_id: str) -> SkyObject:
    """The object an id from :func:`search` names; any other text is searched and its best match taken."""
    kind, _, rest = object_id.partition(":")
    if kind == "body" and rest in _BODY_KIND:
        return _body(rest)
    if kind == "star" and _fold(rest) in _stars():
        return _stars()[_fold(rest)]
    if kind == "dso" and re.fullmatch(r"[A-Za-z0-9 +_.-]{1,40}", rest):
        rows = _ongc(f"SELECT {_DSO_COLUMNS} FROM objects WHERE name = ?", (rest,))
        found = _dso(rows[0]) if rows else None
        if found:
            return found
    if kind == "radec":
        coords = parse_coordinates(rest.replace(",", " ")) if "," in rest else None
        if coords:
            return _coordinate_object(float(rest.split(",")[0]), coords[1])
    matches = search(object_id, 1)
    if not matches:
        raise ObjectError(f"nothing called {object_id.strip()!r} in the catalogues")
    return matches[0]


# -- apparent place ------------------------------------------------------------------------------------


def _observer(site: Site, when: datetime) -> Any:
    import ephem

    obs = ephem.Observer()
    obs.lat, obs.lon = math.radians(site.latitude), math.radians(site.longitude)
    obs.elevation = site.elevation
    obs.date = ephem.Date(when.astimezone(timezone.utc).replace(tzinfo=None))
    obs.pressure = 0.0  # geometric: the mount's frame has no refraction
    return obs


def _ephem_body(obj: SkyObject) -> Any:
    import ephem

    if obj.body is not None:
        return getattr(ephem, obj.body)()
    assert obj.ra_hours is not None and obj.dec_deg is not None
    fixed = ephem.FixedBody()
    fixed._ra, fixed._dec = math.radians(obj.ra_hours * 15.0), math.radians(obj.dec_deg)
    fixed._pmra, fixed._pmdec = obj.pm_ra_mas, obj.pm_dec_mas  # mas/yr, as PyEphem's own star list
    fixed._epoch = ephem.J2000  # equinox and epoch of the position
    return fixed


def apparent(obj: SkyObject, site: Site, when: datetime) -> Apparent:
    """Topocentric apparent RA/Dec of date, Alt/Az, and the rise/transit/set around ``when``."""
    obs = _observer(site, when)
    target = _ephem_body(obj)
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
