"""Alpaca request parameters: name-casing rules, transaction IDs and strict value parsers.

Python's own parsers are too lenient for the wire: ``int()`` and ``float()`` accept surrounding
whitespace, ``_`` digit separators and non-ASCII digits, and ``float()`` accepts ``nan``/``inf``.
Alpaca says such values are unparseable (HTTP 400, the member never runs), so every value goes
through the strict parsers here. Out-of-range but well-formed values are *not* rejected here:
range rules are ASCOM semantics (HTTP 200 + 0x401) and belong to the Telescope.
"""

from __future__ import annotations

import math
import re
from collections.abc import Callable, Mapping
from datetime import datetime, timedelta, timezone
from urllib.parse import unquote_plus

from alpaca_zwo._exceptions import AlpacaZwoError
from alpaca_zwo.alpaca.members import Param, ValueType

UINT32_MAX = 4294967295
_INT32_MIN, _INT32_MAX = -(2**31), 2**31 - 1

_FLOAT = re.compile(r"[+-]?(?:[0-9]+(?:\.[0-9]*)?|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
_UTC_DATE = re.compile(
    r"([0-9]{4})-([0-9]{2})-([0-9]{2})T([0-9]{2}):([0-9]{2}):([0-9]{2})(?:\.([0-9]+))?"
    r"(?:(Z)|([+-])([0-9]{2}):([0-9]{2}))"
)


class BadRequest(AlpacaZwoError):
    """Raised when a request cannot be understood; answered HTTP 400 text/plain and the member never runs."""

    def __init__(self, message: str) -> None:
        self.message = message
        super().__init__(message)


def _bad_value(name: str, text: str, expected: str) -> BadRequest:
    return BadRequest(f"Parameter {name}={text!r} is not a valid {expected}")


def parse_uint32(text: str) -> int | None:
    """Strict uint32 (ASCII digits only); ``None`` when invalid, for callers that choose their own error."""
    if text.isascii() and text.isdigit() and len(text) <= 10:
        value = int(text)
        if value <= UINT32_MAX:
            return value
    return None


def parse_id(name: str, text: str | None) -> int:
    """ClientID / ClientTransactionID: absent means 0; present but not a uint32 is a bad request."""
    if text is None:
        return 0
    value = parse_uint32(text)
    if value is None:
        raise _bad_value(name, text, "unsigned 32-bit integer")
    return value


def parse_bool(name: str, text: str) -> bool:
    """``true``/``false`` in any casing (ASCOM clients send ``True``/``False``)."""
    lowered = text.lower()
    if lowered == "true":
        return True
    if lowered == "false":
        return False
    raise _bad_value(name, text, "boolean (true or false)")


def parse_int(name: str, text: str) -> int:
    """Optional sign and ASCII digits, within int32 (every integer parameter is int32 in the spec)."""
    digits = text[1:] if text[:1] in ("+", "-") else text
    if digits.isascii() and digits.isdigit() and len(digits) <= 10:
        value = int(text)
        if _INT32_MIN <= value <= _INT32_MAX:
            return value
    raise _bad_value(name, text, "32-bit integer")


def parse_float(name: str, text: str) -> float:
    """Period decimal, optional exponent, finite; no separators, no padding, no nan/inf."""
    if _FLOAT.fullmatch(text):
        value = float(text)
        if math.isfinite(value):
            return value
    raise _bad_value(name, text, "finite number (period decimal, no thousands separators)")


def parse_str(name: str, text: str) -> str:
    """Strings pass through; an empty string is a legitimate value (e.g. Action parameters)."""
    return text


def parse_utc_date(name: str, text: str) -> datetime:
    """ISO 8601 ``YYYY-MM-DDTHH:MM:SS[.f{1,7}]Z`` as the spec requires; also an explicit ``±HH:MM``
    offset, because alpyca sends ``datetime.isoformat()``. Sub-microsecond digits are truncated."""
    match = _UTC_DATE.fullmatch(text)
    if match is not None:
        year, month, day, hour, minute, second, fraction, zulu, sign, off_h, off_m = match.groups()
        micro = int((fraction or "0").ljust(7, "0")[:6])
        try:
            stamp = datetime(int(year), int(month), int(day), int(hour), int(minute), int(second), micro,
                             tzinfo=timezone.utc)
            if not zulu:
                if int(off_h) > 23 or int(off_m) > 59:
                    raise ValueError("offset out of range")
                offset = timedelta(hours=int(off_h), minutes=int(off_m))
                stamp -= offset if sign == "+" else -offset
        except (ValueError, OverflowError):
            pass
        else:
            return stamp
    raise _bad_value(name, text, "UTC date (ISO 8601, e.g. 2024-01-31T21:05:00.1234567Z)")


PARSERS: dict[ValueType, Callable[[str, str], object]] = {
    ValueType.BOOL: parse_bool,
    ValueType.INT: parse_int,
    ValueType.FLOAT: parse_float,
    ValueType.STR: parse_str,
    ValueType.UTCDATE: parse_utc_date,
}


def split_pairs(text: str) -> list[tuple[str, str]]:
    """``urllib.parse.parse_qsl(text, keep_blank_values=True)``, about five times faster.

    Blank values must survive (``ClientID=`` is a bad ID, not an absent one), and this runs on
    every request; decoding is skipped for the usual plain ``Name=value`` pairs.
    """
    pairs = []
    for pair in text.split("&"):
        if not pair:
            continue
        name, _, value = pair.partition("=")
        if "%" in pair or "+" in pair:
            name, value = unquote_plus(name), unquote_plus(value)
        pairs.append((name, value))
    return pairs


def query_fields(query_string: str) -> dict[str, str]:
    """GET parameters keyed by *lower-cased* name: Alpaca query names are case-insensitive."""
    if not query_string:
        return {}
    return {key.lower(): value for key, value in split_pairs(query_string)}


def form_fields(body: bytes) -> dict[str, str]:
    """PUT form parameters keyed by their exact name: Alpaca form names are case-sensitive."""
    if not body:
        return {}
    try:
        text = body.decode("utf-8")
    except UnicodeDecodeError:
        raise BadRequest("Request body is not UTF-8 application/x-www-form-urlencoded data") from None
    return dict(split_pairs(text))


def missing(param: Param, fields: Mapping[str, str], case_sensitive: bool) -> BadRequest:
    """The 400 for an absent required parameter, pointing out a miscased name when that is the cause."""
    if case_sensitive:
        near = [key for key in fields if key.lower() == param.name.lower()]
        if near:
            return BadRequest(f"Missing parameter {param.name}: form parameter names are case-sensitive "
                              f"and {near[0]!r} does not match")
    return BadRequest(f"Missing parameter {param.name}")
