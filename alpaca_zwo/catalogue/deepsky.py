"""Deep-sky objects from OpenNGC's database as pyongc ships it: designations, common names, the chart's list.

OpenNGC (github.com/mattiaverga/OpenNGC, CC-BY-SA-4.0) is read with sqlite3 (``pyongc.ongc`` would load
numpy). It has the NGC and IC, the Messier numbers, every Caldwell number (its own ``C014``, ``C099``
rows where an object has no NGC/IC entry, an identifier elsewhere), Barnard, Melotte, Collinder, LBN,
PGC, UGC and HCG identifiers, one Sharpless number (Sh2-155, the Cave Nebula) and 151 objects' common
names; ``dso_names.csv`` adds the common names it lacks (LMC, Heart Nebula, Jewel Box: sources there).
Without pyongc (32-bit ARM without piwheels) every function finds nothing.
"""

from __future__ import annotations

import contextlib
import functools
import math
import re
import sqlite3
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from typing import Any

from ..sky import angular_separation
from . import data_text
from .naming import SkyObject, fold, name_key, words_match

KINDS = {
    "*": "star", "**": "double star", "*Ass": "stellar association", "OCl": "open cluster",
    "GCl": "globular cluster", "Cl+N": "cluster with nebula", "G": "galaxy", "GPair": "galaxy pair",
    "GTrpl": "galaxy triplet", "GGroup": "galaxy group", "PN": "planetary nebula", "HII": "emission nebula",
    "DrkN": "dark nebula", "EmN": "emission nebula", "Neb": "nebula", "RfN": "reflection nebula",
    "SNR": "supernova remnant", "Nova": "nova",
}
# The chart's symbol of each OpenNGC type; nebulae (and the rest) are squares.
SHAPES = {"G": "galaxy", "GPair": "galaxy", "GTrpl": "galaxy", "GGroup": "galaxy", "OCl": "open", "*Ass": "open",
          "GCl": "globular", "PN": "planetary", "DrkN": "dark", "**": "open", "*": "open"}
CHART_BRIGHT = 5.0  # the chart adds every object brighter than this to the Messier and Caldwell lists
_COLUMNS = "name, type, ra, dec, vmag, bmag, messier, commonnames, ngc, ic, identifiers, majax"

# What people type before a number -> the identifier's prefix in OpenNGC (matched zero-padded to any width).
_PREFIXES = {"c": "C", "caldwell": "C", "b": "B", "barnard": "B", "mel": "MEL", "melotte": "MEL", "cr": "CL",
             "cl": "CL", "collinder": "CL", "lbn": "LBN", "pgc": "PGC", "leda": "PGC", "ugc": "UGC", "hcg": "HCG"}
_DESIGNATION = re.compile(r"(m|messier|ngc|ic|sh\s*2|sharpless(?:\s*2)?|" + "|".join(_PREFIXES)
                          + r")\s*-?\s*0*(\d{1,6})\s*([a-z]?)")


@dataclass(frozen=True)
class ChartObject:
    """A deep-sky object the chart draws: the object, the symbol's shape and its size (degrees across)."""

    obj: SkyObject
    shape: str
    size_deg: float

    @property
    def label(self) -> str:
        """The chart's short name: the Messier number, else the shortest common name of up to 16 letters
        ("LMC", "Omega Centauri", "Jewel Box"), else the designation."""
        if re.fullmatch(r"M\d+", self.obj.name):
            return self.obj.name
        names = [n for n in (self.obj.name, *self.obj.common_names) if not re.match(r"(NGC|IC) ", n) and len(n) <= 16]
        return min(names, key=len) if names else self.obj.name


@functools.lru_cache(maxsize=1)
def _database() -> Path:
    return Path(str(resources.files("pyongc").joinpath("ongc.db")))


def _rows(sql: str, params: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    """Rows of OpenNGC's database; none where pyongc is not installed."""
    try:
        path = _database()
    except ModuleNotFoundError:
        return []
    with contextlib.closing(sqlite3.connect(f"file:{path}?mode=ro", uri=True)) as db:
        return db.execute(sql, params).fetchall()


def _named(names: list[str]) -> list[SkyObject]:
    if not names:
        return []
    marks = ",".join("?" * len(names))
    rows = {r[0]: r for r in _rows(f"SELECT {_COLUMNS} FROM objects WHERE name IN ({marks})", tuple(names))}
    return [o for o in (_object(rows[n]) for n in names if n in rows) if o is not None]


def by_name(name: str) -> SkyObject | None:
    """The object of OpenNGC's name ("NGC0224", "C014"), its duplicates followed."""
    found = _named([name])
    return found[0] if found else None


def _object(row: tuple[Any, ...]) -> SkyObject | None:
    name, kind, ra, dec, vmag, bmag, messier, common, ngc, ic, identifiers, _size = row
    if kind == "Dup":  # a duplicate entry: the object lives under its NGC/IC name
        target = f"NGC{ngc}" if ngc else f"IC{ic}" if ic else None
        return by_name(target) if target and target != name else None
    if ra is None or dec is None or kind == "NonEx":
        return None
    label = pretty(name)
    commons = [re.sub(r"^the ", "", n) for n in (common or "").split(",") if n]
    commons += [n for n in _extra_names().get(name, ()) if n not in commons]
    others = [pretty(i.strip()) for i in (identifiers or "").split(",") if re.fullmatch(r"(C|SH 2-)\s*\d+", i.strip())]
    if messier:
        title = f"M{int(messier)}"
    elif name.startswith(("NGC", "IC")) or not commons:
        title = label
    else:
        title = commons[0]
    aliases = tuple(dict.fromkeys(a for a in (label, *others) if a != title))
    return SkyObject(f"dso:{name}", title, KINDS.get(kind, kind), vmag if vmag is not None else bmag,
                     math.degrees(ra) / 15.0, math.degrees(dec), aliases=aliases,
                     common_names=tuple(n for n in commons if n != title))


def pretty(name: str) -> str:
    """OpenNGC's names as people write them: "NGC0224" → "NGC 224", "C014" → "C14", "SH 2-155" → "Sh2-155"."""
    m = re.fullmatch(r"(NGC|IC|Mel|MEL|Cl|CL|LBN|ESO|UGC|PGC|HCG|C|B|H|M)\s*0*(\d+)(.*)", name)
    if not m:
        m2 = re.fullmatch(r"SH 2-0*(\d+)", name)
        return f"Sh2-{m2.group(1)}" if m2 else name
    prefix = {"MEL": "Mel", "CL": "Cr", "Cl": "Cr"}.get(m.group(1), m.group(1))
    space = "" if prefix in ("C", "B", "M") else " "
    return f"{prefix}{space}{m.group(2)}{m.group(3)}"


@functools.lru_cache(maxsize=1)
def _extra_names() -> dict[str, tuple[str, ...]]:
    """``dso_names.csv``: OpenNGC name -> the common names it lacks."""
    extra: dict[str, list[str]] = {}
    table = data_text("dso_names.csv")
    for line in table.splitlines()[1:]:
        if line and not line.startswith(("#", "name,")):
            common, target, _source = line.split(",", 2)
            extra.setdefault(target, []).append(common)
    return {k: tuple(v) for k, v in extra.items()}


# -- designations ------------------------------------------------------------------------------------


def designation(query: str) -> tuple[str, str] | None:
    """("NGC", "224") style catalogue and number of "NGC 224", "ngc224", "M 31", "C14", "Caldwell 14",
    "Sh2-155", "Cr 399"; None when the text is not a catalogue designation."""
    m = re.fullmatch(_DESIGNATION, fold(query))
    if not m:
        return None
    cat, number, suffix = m.groups()
    cat = re.sub(r"\s+", "", cat)
    if cat in ("m", "messier"):
        return ("M", number) if not suffix else None
    if cat.startswith(("sh", "sharpless")):
        return ("Sh2", number) if not suffix else None
    if cat in ("ngc", "ic"):
        return cat.upper(), number + suffix.upper()
    return (_PREFIXES[cat], number) if not suffix else None


def by_designation(query: str) -> SkyObject | None:
    """The object a catalogue designation names, or None (not one, or not in OpenNGC)."""
    key = designation(query)
    if key is None:
        return None
    cat, number = key
    digits = re.match(r"\d+", number)
    assert digits is not None
    rest = number[digits.end():]
    if cat == "M":
        rows = _rows(f"SELECT {_COLUMNS} FROM objects WHERE messier = ? ORDER BY type = 'Dup'", (f"{int(number):03d}",))
    elif cat in ("NGC", "IC"):
        rows = _rows(f"SELECT {_COLUMNS} FROM objects WHERE name = ?", (f"{cat}{int(digits.group()):04d}{rest}",))
    elif cat == "Sh2":
        rows = [r for r in _rows(f"SELECT {_COLUMNS} FROM objects WHERE identifiers LIKE ?", (f"%SH 2-{int(number)}%",))
                if f"SH 2-{int(number)}" in [i.strip() for i in (r[10] or "").split(",")]]
    else:
        forms = tuple(f"{cat}{int(number):0{width}d}" for width in range(1, 7))
        names = _rows(f"SELECT name FROM objIdentifiers WHERE identifier IN ({','.join('?' * len(forms))})", forms)
        rows = _rows(f"SELECT {_COLUMNS} FROM objects WHERE name = ?", (names[0][0],)) if names else []
    for row in rows:
        found = _object(row)
        if found is not None:
            return found
    return None


# -- common names ----------------------------------------------------------------------------------


@functools.lru_cache(maxsize=1)
def _common_names() -> tuple[tuple[str, str, str], ...]:
    """(name key, the name as written, OpenNGC name) of every common name, OpenNGC's and ``dso_names.csv``'s."""
    found: list[tuple[str, str, str]] = []
    for name, common in _rows("SELECT name, commonnames FROM objects WHERE commonnames != '' AND type != 'Dup'"):
        for written in common.split(","):
            written = re.sub(r"^the ", "", written.strip())
            if written:
                found.append((name_key(written), written, name))
    for name, extra in _extra_names().items():
        found += [(name_key(written), written, name) for written in extra]
    return tuple(found)


def by_common_name(query_key: str) -> dict[str, list[tuple[SkyObject, str]]]:
    """Matches of a name key: "exact", "prefix" (the name begins so) and "words" (each word typed begins a
    word of the name, in order), each a list of (object, the name it matched by)."""
    ranks: dict[str, list[tuple[str, str]]] = {"exact": [], "prefix": [], "words": []}
    for key, written, name in _common_names():
        if key == query_key:
            ranks["exact"].append((name, written))
        elif key.startswith(query_key):
            ranks["prefix"].append((name, written))
        elif len(query_key) >= 3 and words_match(query_key, key):
            ranks["words"].append((name, written))
    result: dict[str, list[tuple[SkyObject, str]]] = {}
    for rank, pairs in ranks.items():
        first = dict(reversed(pairs))  # one match per object: its first name of that rank
        objects = {o.id: o for o in _named(list(first))}
        result[rank] = [(objects[f"dso:{n}"], w) for n, w in first.items() if f"dso:{n}" in objects]
    return result


# -- the chart's list --------------------------------------------------------------------------------


@functools.lru_cache(maxsize=1)
def chart_objects() -> tuple[ChartObject, ...]:
    """What the sky chart draws: the Messier and Caldwell objects (the showpiece lists of both hemispheres)
    and any other object brighter than ``CHART_BRIGHT`` (the Magellanic Clouds, IC 2391, NGC 3532 ...)
    unless it lies within a degree of one already drawn (NGC 869/884 are the Double Cluster, C14)."""
    listed = [r[0] for r in _rows("SELECT name FROM objects WHERE messier != '' ORDER BY messier")]
    listed += [r[0] for r in _rows("SELECT name FROM objIdentifiers WHERE identifier GLOB 'C[0-9][0-9][0-9]' "
                                   "ORDER BY identifier")]
    bright = _rows("SELECT name FROM objects WHERE type NOT IN ('Dup', 'NonEx', '*', '**', 'Nova', 'Other') "
                   "AND coalesce(vmag, bmag) <= ? ORDER BY coalesce(vmag, bmag)", (CHART_BRIGHT,))
    drawn: dict[str, ChartObject] = {}
    sizes = {r[0]: (r[1], r[2]) for r in _rows("SELECT name, type, majax FROM objects")}
    showpieces = {o.id for o in _named(listed)}
    for obj in _named(listed + [r[0] for r in bright]):
        if obj.id in drawn:
            continue
        if obj.id not in showpieces and any(_apart(obj, other.obj) < 1.0 for other in drawn.values()):
            continue
        kind, majax = sizes.get(obj.id.removeprefix("dso:"), ("", None))
        drawn[obj.id] = ChartObject(obj, SHAPES.get(kind, "nebula"), round((majax or 0.0) / 60.0, 3))
    return tuple(sorted(drawn.values(), key=lambda c: 99.0 if c.obj.magnitude is None else c.obj.magnitude))



def _apart(a: SkyObject, b: SkyObject) -> float:
    assert a.ra_hours is not None and a.dec_deg is not None and b.ra_hours is not None and b.dec_deg is not None
    return angular_separation(a.ra_hours, a.dec_deg, b.ra_hours, b.dec_deg)
