"""What the HTTP layer needs from a device, and how it finds the handler of each member.

A device is its identity (``device_name``, ``unique_id``: the management API reads them) plus the
handlers the member table names: each row says which part of the device answers it (``owner``, an
attribute of the device; none: the device itself) or gives its constant, which needs no handler.
So the contract lives in one place, the table, and :func:`missing_handlers` holds a device to it
when the app is built: a handler that is missing, or takes other parameters than its row says,
stops the server at start, not per request (and ``tests/telescope/test_member_owners.py`` holds the
real Telescope to the table's types too). Handlers return plain Python values; the HTTP layer owns
every JSON detail (key casing, date format, AxisRates and DeviceState shapes) and turns
:class:`~alpaca_zwo._exceptions.AlpacaError` into ErrorNumber/ErrorMessage.
"""

from __future__ import annotations

import inspect
from collections.abc import Callable, Iterable
from typing import Any, Protocol

from alpaca_zwo.alpaca.members import Member

#: AxisRates value: (minimum, maximum) pairs in degrees per second.
AxisRateList = list[tuple[float, float]]
#: DeviceState value: (ASCOM property name, value) pairs; datetimes must be timezone-aware.
DeviceStateList = list[tuple[str, object]]


class AlpacaDevice(Protocol):
    """A device as the HTTP layer serves it: its identity here, its members' handlers by the member table."""

    @property
    def device_name(self) -> str:
        """Shown by /management/v1/configureddevices; read per request so renames show up at once."""

    @property
    def unique_id(self) -> str:
        """Persistent, globally unique ID (a UUID) for /management/v1/configureddevices."""


def handler_for(device: object, member: Member) -> Callable[..., Any] | None:
    """The callable that answers ``member`` on ``device``: the constant's, or the owner's handler (None: absent)."""
    if member.constant is not None:
        value = member.constant.value
        return lambda: value
    owner = device if member.owner is None else getattr(device, member.owner, None)
    handler = getattr(owner, member.handler, None)
    return handler if callable(handler) else None


def _wrong_parameters(handler: Callable[..., Any], member: Member) -> bool:
    """The handler cannot be called the way the HTTP layer calls it for ``member``."""
    try:
        parameters = list(inspect.signature(handler).parameters.values())
    except (TypeError, ValueError):  # no signature to read (a builtin): trust it
        return False
    if any(p.kind in (p.VAR_POSITIONAL, p.VAR_KEYWORD) for p in parameters):
        return False
    required = [p for p in parameters if p.default is p.empty]
    if member.setter:
        return len(parameters) < 1 or len(required) > 1 or parameters[0].kind is parameters[0].KEYWORD_ONLY
    names = [p.name for p in parameters]
    return (sorted(names) != sorted(p.kwarg for p in member.params)
            or any(p.kind is p.POSITIONAL_ONLY for p in parameters))


def missing_handlers(device: object, members: Iterable[Member]) -> list[str]:
    """What the device lacks (handlers as ``owner.handler``, or taking the wrong parameters), so a half-written
    device fails at start-up, not per request."""
    missing = []
    for m in members:
        if m.constant is not None:
            continue
        handler = handler_for(device, m)
        if handler is None:
            missing.append(m.answered_by)
        elif _wrong_parameters(handler, m):
            missing.append(f"{m.answered_by} taking {'(value)' if m.setter else [p.kwarg for p in m.params]}")
    missing += [attr for attr in ("device_name", "unique_id") if not hasattr(device, attr)]
    return missing
