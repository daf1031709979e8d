"""J2000 coordinates as people type them into the page's search (issue 33 item 3). Pure: no imports of ours.

Every form the search box's placeholder shows and the common ones: sexagesimal with units
(``5h35m17s -5°23'28"``, ``5h35m −5°23′``, ``05h 35.3m, -05d 23m``), with colons (``05:35:17 -05:23:28``,
``5:35 -5:23``), with spaces (``05 35 17 -05 23 28``, ``5 35 -5 23``), decimal hours with ``h``
(``5.588h -5.39``) and decimal degrees with ``°`` or ``d`` (``83.82° -5.39°``); Unicode minus signs,
primes and double primes; "RA"/"Dec" labels, commas and slashes between the two. A sexagesimal RA is in
hours (the convention of every catalogue); a bare decimal RA over 24 can only be degrees; a bare decimal
RA of 24 or less could be either (``5.588 -5.39``), so both readings are returned and the page asks.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

_SAME = str.maketrans({"−": "-", "–": "-", "—": "-", "‐": "-", "‒": "-", "﹣": "-", "－": "-", "＋": "+",
                       "′": "'", "’": "'", "‘": "'", "´": "'", "ʹ": "'", "`": "'",
                       "″": '"', "”": '"', "“": '"', "ʺ": '"', "º": "°", "˚": "°", "\u00a0": " ",
                       ",": " ", ";": " ", "/": " "})
_LABELS = re.compile(r"(?i)(?<![a-z])(?:ra|dec|decl|j2000(?:\.0)?|α|δ)(?![a-z])\s*[:=]?")
_TOKEN = re.compile(r"\s*([+-]?)\s*(\d+(?:\.\d*)?|\.\d+)\s*(h|m|s|°|d|'|\"|:)?", re.IGNORECASE)
_LEVEL = {"h": 0, "°": 0, "d": 0, "m": 1, "'": 1, "s": 2, '"': 2}


class CoordinateError(ValueError):
    """Text that is plainly coordinates but cannot be a place (minutes over 60, Dec over 90, ...)."""


@dataclass(frozen=True)
class CoordinateReading:
    """One meaning of typed coordinates: J2000 RA (hours) and Dec (degrees), and how the RA was read."""

    ra_hours: float
    dec_deg: float
    ra_unit: str  # "hours" or "degrees"
    ambiguous: bool = False  # a bare decimal RA of 24 or less: hours or degrees


@dataclass(frozen=True)
class _Token:
    sign: str
    number: str
    unit: str  # "" when none


@dataclass(frozen=True)
class _Angle:
    value: float  # unsigned, in the angle's first unit
    negative: bool
    unit: str  # "h", "d" or "" (bare numbers or colons)
    parts: int
    sexagesimal_ok: bool  # minutes and seconds under 60


def parse(text: str) -> list[CoordinateReading] | None:
    """The readings of ``text`` as coordinates (one, or two when ambiguous); None when it is not coordinates.
    Raises :class:`CoordinateError` for coordinates out of range or whose RA and Dec cannot be told apart."""
    tokens = _tokens(text)
    if tokens is None or len(tokens) < 2:
        return None
    splits = [(ra, dec) for k in range(1, len(tokens))
              if (ra := _angle(tokens[:k], is_ra=True)) and (dec := _angle(tokens[k:], is_ra=False))]
    if not splits:
        return None
    good = [(ra, dec) for ra, dec in splits if ra.sexagesimal_ok and dec.sexagesimal_ok]
    if not good:
        raise CoordinateError(f"{text.strip()!r}: minutes and seconds must be under 60")
    splits = good
    if len(splits) > 1:
        splits = _preferred(splits, tokens)
    ra, dec = splits[0]
    dec_deg = -dec.value if dec.negative else dec.value
    if not -90.0 <= dec_deg <= 90.0:
        raise CoordinateError(f"{text.strip()!r}: Dec must be between -90° and +90°")
    return _readings(text, ra, dec_deg)


def _tokens(text: str) -> list[_Token] | None:
    clean = _LABELS.sub(" ", text.translate(_SAME)).replace("''", '"').strip()
    tokens: list[_Token] = []
    at = 0
    while at < len(clean):
        m = _TOKEN.match(clean, at)
        if m is None or m.end() == at:
            return None if clean[at:].strip() else tokens
        tokens.append(_Token(m.group(1), m.group(2), (m.group(3) or "").lower()))
        at = m.end()
    return tokens


def _angle(tokens: list[_Token], is_ra: bool) -> _Angle | None:
    """One angle's tokens read as degrees or hours with up to two sexagesimal parts; None if they are not one."""
    if len(tokens) > 3 or any(t.sign for t in tokens[1:]) or (is_ra and tokens[0].sign):
        return None
    if not is_ra and any(t.unit == "h" for t in tokens):
        return None
    if any("." in t.number for t in tokens[:-1]):
        return None  # only the last part may have decimals
    units = [t.unit for t in tokens]
    if ":" in units:
        if units[:-1] != [":"] * (len(tokens) - 1) or units[-1] not in ("", "s", '"'):
            return None
        unit = ""
    elif all(not u for u in units):
        unit = ""
    else:
        levels = [_LEVEL.get(u) for u in units]
        if units[-1] == "":
            levels[-1] = len(tokens) - 1
        if levels != list(range(len(tokens))):
            return None
        unit = "h" if units[0] == "h" else "d"
    values = [float(t.number) for t in tokens]
    value = sum(v / 60.0 ** i for i, v in enumerate(values))
    return _Angle(value, tokens[0].sign == "-", unit, len(tokens), all(v < 60.0 for v in values[1:]))


def _preferred(splits: list[tuple[_Angle, _Angle]], tokens: list[_Token]) -> list[tuple[_Angle, _Angle]]:
    """Where RA ends when several places could: at a signed number, else where the two have as many parts."""
    signed = [s for s in splits if tokens[s[0].parts].sign]
    if len(signed) == 1:
        return signed
    even = [s for s in splits if s[0].parts == s[1].parts]
    if len(even) == 1:
        return even
    raise CoordinateError("cannot tell where the RA ends and the Dec begins: give the Dec its sign "
                          "(+ or -) or units, e.g. 5h35m17s -5°23'28\"")


def _readings(text: str, ra: _Angle, dec_deg: float) -> list[CoordinateReading]:
    if ra.unit == "h" or (not ra.unit and ra.parts > 1):
        hours = [("hours", ra.value)]
    elif ra.unit == "d" or ra.value > 24.0:
        hours = [("degrees", ra.value / 15.0)]
    elif ra.value == 0.0:
        hours = [("hours", 0.0)]  # 0 h and 0° are one place
    else:
        hours = [("hours", ra.value), ("degrees", ra.value / 15.0)]
    if any(not 0.0 <= h < 24.0 for _, h in hours):
        raise CoordinateError(f"{text.strip()!r}: RA must be 0..24 h (0..360°)")
    return [CoordinateReading(h, dec_deg, unit, ambiguous=len(hours) > 1) for unit, h in hours]
