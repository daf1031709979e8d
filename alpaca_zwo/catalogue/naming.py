"""What the search finds and how it compares names: the ``SkyObject`` record and the name keys (issue 33 item 3).

Pure, with no imports of ours but the package's data files: ``objects`` (stars, bodies, the search) and
``deepsky`` (OpenNGC) share it.
A name key folds what people type and what catalogues print into one form: case, accents, apostrophes
and a leading "the" dropped; Greek letters spelled out ("ω Cen", "omega Cen"; OpenNGC's "tet Car" is
"theta Car"); a constellation's genitive made its abbreviation ("Alpha Centauri" is "alpha cen", "Eta
Carinae Nebula" is OpenNGC's "eta Car Nebula"; the 88 from ``constellations.csv``, the IAU's list).
"""

from __future__ import annotations

import functools
import re
import unicodedata
from dataclasses import dataclass, field
from typing import Any

from . import data_text

SIDEREAL, LUNAR, SOLAR = 0, 1, 2  # ASCOM DriveRates

GREEK = {
    "alpha": "α", "beta": "β", "gamma": "γ", "delta": "δ", "epsilon": "ε", "zeta": "ζ", "eta": "η",
    "theta": "θ", "iota": "ι", "kappa": "κ", "lambda": "λ", "mu": "μ", "nu": "ν", "xi": "ξ", "omicron": "ο",
    "pi": "π", "rho": "ρ", "sigma": "σ", "tau": "τ", "upsilon": "υ", "phi": "φ", "chi": "χ", "psi": "ψ",
    "omega": "ω",
}
GREEK_ABBREV = {name[:3]: letter for name, letter in GREEK.items()}  # "Alp Lyr", the Bright Star Catalogue's
GREEK_ABBREV.update({"ups": "υ", "omi": "ο", "ome": "ω", "eps": "ε", "tet": "θ", "the": "θ"})
_LATIN = {letter: name for name, letter in GREEK.items()}


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
    aliases: tuple[str, ...] = field(default=())  # designations and other names ("α Lyr", "NGC 224", "C14")
    pm_ra_mas: float = 0.0  # proper motion, mas/yr (RA component times cos Dec), epoch J2000
    pm_dec_mas: float = 0.0
    common_names: tuple[str, ...] = field(default=())  # "Andromeda Galaxy" (the name when it is the title)

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
                "aliases": list(self.aliases), "common_names": list(self.common_names)}


def fold(text: str) -> str:
    """Case, accents and spacing folded: "Alnaïr " and "alnair" are one key."""
    text = unicodedata.normalize("NFKD", text.casefold())
    return re.sub(r"\s+", " ", "".join(c for c in text if not unicodedata.combining(c))).strip()


@functools.lru_cache(maxsize=1)
def constellation_table() -> tuple[tuple[str, str, str], ...]:
    """The 88 as the IAU lists them: (abbreviation, name, genitive), e.g. ("Cru", "Crux", "Crucis")."""
    rows = [line.split(",") for line in data_text("constellations.csv").splitlines()
            if line[:1].isupper() and not line.startswith("abbr,")]
    return tuple((abbr, name, genitive) for abbr, name, genitive in rows)


@functools.lru_cache(maxsize=1)
def _constellations() -> tuple[dict[str, str], re.Pattern[str]]:
    """Folded genitive -> folded abbreviation, and one pattern finding any genitive as whole words."""
    genitives = {fold(genitive): fold(abbr) for abbr, _name, genitive in constellation_table()}
    words = sorted(genitives, key=len, reverse=True)  # "canis majoris" before any shorter overlap
    return genitives, re.compile(r"\b(" + "|".join(re.escape(w) for w in words) + r")\b")


def constellation_abbreviations() -> set[str]:
    """The 88 IAU abbreviations, folded ("cen", "cma")."""
    return set(_constellations()[0].values())


def with_abbreviations(folded: str) -> str:
    """A folded text with each constellation genitive replaced by its abbreviation."""
    genitives, pattern = _constellations()
    return pattern.sub(lambda m: genitives[m.group(1)], folded)


def name_key(text: str) -> str:
    """The form two names are compared in (the module's docstring says what is folded)."""
    folded = fold(text).replace("&", " and ")
    folded = re.sub(r"[’'`.]", "", folded)
    words = re.sub(r"[-_/,;:()]+", " ", folded).split()
    if words and words[0] == "the":
        words = words[1:]
    if len(words) > 1 and words[0] in GREEK_ABBREV:  # OpenNGC's "tet Car Cluster", "lam Cen Nebula"
        words[0] = _LATIN[GREEK_ABBREV[words[0]]]
    words = [_LATIN.get(w, w) for w in words]
    return with_abbreviations(" ".join(words))


def words_match(query_key: str, key: str) -> bool:
    """Every word typed begins a word of the name, in order ("jewel box" in "herschels jewel box")."""
    words = key.split()
    at = 0
    for typed in query_key.split():
        while at < len(words) and not words[at].startswith(typed):
            at += 1
        if at == len(words):
            return False
        at += 1
    return True
