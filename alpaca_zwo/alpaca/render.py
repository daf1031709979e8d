"""Alpaca JSON replies: the exact key casing and the wire shapes of structured values.

Handlers return plain Python (tuples, aware datetimes); this module is the only place that knows
AxisRates are ``{"Minimum","Maximum"}`` objects, DeviceState is ``{"Name","Value"}`` objects and
dates are ISO 8601 with seven fractional digits and ``Z`` (what the ASCOM .NET client writes and
parses). NaN or infinity from a device is a bug, so encoding refuses it (-> HTTP 500).
"""

from __future__ import annotations

import json
import math
import threading
from collections.abc import Callable, Iterable
from datetime import datetime, timezone
from json.encoder import encode_basestring_ascii
from typing import Any

from alpaca_zwo.alpaca.members import ValueType

# One reusable encoder: json.dumps() with non-default options builds a new one per call.
_encode = json.JSONEncoder(allow_nan=False, check_circular=False, separators=(",", ":")).encode


class TransactionCounter:
    """ServerTransactionID source: unique per reply, from 1, wrapping to 1 after the uint32 maximum."""

    MAX = 4294967295

    def __init__(self, start: int = 1) -> None:
        self._next = start
        self._lock = threading.Lock()

    def next(self) -> int:
        with self._lock:
            value = self._next
            self._next = 1 if value >= self.MAX else value + 1
        return value


def format_utc_date(value: datetime) -> str:
    """``2024-01-31T21:05:00.1234560Z``; a naive datetime is refused because its zone is a guess."""
    if value.tzinfo is None or value.utcoffset() is None:
        raise ValueError(f"naive datetime {value!r} cannot be sent as a UTC date")
    d = value.astimezone(timezone.utc)
    return (f"{d.year:04d}-{d.month:02d}-{d.day:02d}T{d.hour:02d}:{d.minute:02d}:{d.second:02d}"
            f".{d.microsecond:06d}0Z")


def _axis_rates(value: Iterable[tuple[float, float]]) -> list[dict[str, float]]:
    return [{"Minimum": minimum, "Maximum": maximum} for minimum, maximum in value]


def _state_value(value: object) -> object:
    return format_utc_date(value) if isinstance(value, datetime) else value


def _device_state(value: Iterable[tuple[str, object]]) -> list[dict[str, object]]:
    return [{"Name": name, "Value": _state_value(item)} for name, item in value]


#: Per-type conversion to JSON-ready values; types missing here are sent as returned.
RENDERERS: dict[ValueType, Callable[[object], object]] = {
    ValueType.UTCDATE: format_utc_date,  # type: ignore[dict-item]
    ValueType.AXIS_RATES: _axis_rates,  # type: ignore[dict-item]
    ValueType.DEVICE_STATE: _device_state,  # type: ignore[dict-item]
}


def _float(value: float) -> str:
    if value != value or value in (math.inf, -math.inf):
        raise ValueError(f"{value!r} is not valid JSON")
    return float.__repr__(value)


# JSON text of the common scalar types without a trip through the encoder (same output as json).
_SCALARS: dict[type, Callable[[Any], str]] = {
    bool: lambda value: "true" if value else "false",
    int: int.__repr__,
    float: _float,
    str: encode_basestring_ascii,
}


def _json(value: object) -> str:
    fast = _SCALARS.get(type(value))
    return fast(value) if fast is not None else _encode(value)


def value_body(value: object, ctid: int, stid: int) -> bytes:
    """Successful reply of a member that returns a value."""
    return (f'{{"Value":{_json(value)},"ClientTransactionID":{ctid:d},"ServerTransactionID":{stid:d},'
            f'"ErrorNumber":0,"ErrorMessage":""}}').encode()


def method_body(ctid: int, stid: int) -> bytes:
    """Successful reply of a member without a value (the spec's MethodResponse)."""
    return (f'{{"ClientTransactionID":{ctid:d},"ServerTransactionID":{stid:d},'
            f'"ErrorNumber":0,"ErrorMessage":""}}').encode()


def error_body(value: object | None, ctid: int, stid: int, number: int, message: str) -> bytes:
    """ASCOM error reply. ``value`` is the member's ``Member.error_value`` (its type's default, so
    typed clients and the official schema never meet a null); None leaves ``Value`` out, as a
    MethodResponse has none."""
    body: dict[str, object] = {} if value is None else {"Value": value}
    body.update(ClientTransactionID=ctid, ServerTransactionID=stid, ErrorNumber=number, ErrorMessage=message)
    return _encode(body).encode()


def management_body(value: object, ctid: int, stid: int) -> bytes:
    """Management replies carry the same envelope; the error keys are harmless extras there."""
    return value_body(value, ctid, stid)
