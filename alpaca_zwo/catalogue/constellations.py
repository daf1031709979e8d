"""The 88 constellations as things to find: "Crux", "Southern Cross", "Orion", "Cru" (issue 43 point 8).

A constellation has no catalogue place of its own, so each is pointed at the middle of its figure on the
chart: the mean direction of its stars to magnitude 4.5 (``sky_data.json``, each star's constellation read
off its Bayer or Flamsteed designation). That is where someone looking for the Southern Cross wants the
telescope, and the chart draws the same stars. Pure data, no PyEphem.
"""

from __future__ import annotations

import functools
import json
import math

from . import data_text
from .naming import SkyObject, constellation_table, name_key

__all__ = ["KIND", "by_abbreviation", "by_key"]

KIND = "constellation"
#: Popular names of whole constellations beside the IAU's (asterisms inside one are not constellations).
POPULAR = {"Cru": ("Southern Cross",), "UMa": ("Great Bear",), "UMi": ("Little Bear",)}


def _centres() -> dict[str, tuple[float, float]]:
    """Abbreviation -> (RA hours, Dec degrees) of the mean direction of its chart stars (J2000)."""
    sums: dict[str, list[float]] = {}
    for star in json.loads(data_text("sky_data.json"))["stars"]:
        ra, dec, designations = math.radians(star[1]), math.radians(star[2]), star[5]
        named = [d for d in designations.split(";") if " " in d]
        if not named:
            continue
        vector = sums.setdefault(named[0].rsplit(" ", 1)[1], [0.0, 0.0, 0.0])
        vector[0] += math.cos(dec) * math.cos(ra)
        vector[1] += math.cos(dec) * math.sin(ra)
        vector[2] += math.sin(dec)
    return {abbr: (math.degrees(math.atan2(y, x)) % 360.0 / 15.0, math.degrees(math.atan2(z, math.hypot(x, y))))
            for abbr, (x, y, z) in sums.items()}


@functools.lru_cache(maxsize=1)
def _index() -> tuple[dict[str, tuple[SkyObject, str]], dict[str, SkyObject]]:
    """Name key -> (constellation, the form it was found by), and abbreviation -> constellation."""
    centres = _centres()
    keys: dict[str, tuple[SkyObject, str]] = {}
    abbreviations: dict[str, SkyObject] = {}
    for abbr, name, _genitive in constellation_table():
        ra, dec = centres[abbr]
        obj = SkyObject(f"con:{abbr}", name, KIND, None, ra, dec, aliases=(abbr,), common_names=POPULAR.get(abbr, ()))
        abbreviations[abbr.casefold()] = obj
        for form in (name, abbr, *POPULAR.get(abbr, ())):
            keys.setdefault(name_key(form), (obj, form))
    return keys, abbreviations


def by_key(key: str) -> tuple[SkyObject, str] | None:
    """The constellation a name key (:func:`naming.name_key` of what was typed) names, with the form matched."""
    return _index()[0].get(key)


def by_abbreviation(abbr: str) -> SkyObject | None:
    """The constellation of an IAU abbreviation in any letter case ("Cru"), for ids ``con:Cru``."""
    return _index()[1].get(abbr.casefold())
