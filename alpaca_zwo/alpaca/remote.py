"""Reading other Alpaca devices: the observatory's SafetyMonitor and roof, and discovered servers.

A deliberately small client on the standard library (no new dependency): GET a member and return its
``Value``, PUT a member, read the management API. Every failure, whatever its kind (refused connection,
timeout, HTTP 4xx/5xx, a reply that is not the Alpaca envelope, an ASCOM error number), is one
:class:`RemoteError` whose message says what happened, because the caller only needs "this device did
not answer properly" and a line for the page. Proxies from the environment are ignored: the devices are
on the observatory's own network, and a proxy would hide an unreachable monitor behind its own errors.
"""

from __future__ import annotations

import itertools
import json
import urllib.error
import urllib.parse
import urllib.request
from typing import Any

from .._exceptions import AlpacaZwoError

__all__ = ["MAX_REPLY_BYTES", "RemoteDevice", "RemoteError", "get_json"]

#: A device's reply is a small JSON envelope; anything larger is not one.
MAX_REPLY_BYTES = 256 * 1024
_transactions = itertools.count(1)
_opener = urllib.request.build_opener(urllib.request.ProxyHandler({}))


class RemoteError(AlpacaZwoError):
    """Another Alpaca device did not answer, or answered with an error."""


def _request(url: str, timeout: float, data: bytes | None = None) -> Any:
    request = urllib.request.Request(url, data=data, method="PUT" if data is not None else "GET",
                                     headers={"Accept": "application/json", "User-Agent": "alpaca-zwo"})
    try:
        with _opener.open(request, timeout=timeout) as reply:
            body = reply.read(MAX_REPLY_BYTES + 1)
    except urllib.error.HTTPError as exc:
        text = exc.read(200).decode("utf-8", "replace").strip()
        raise RemoteError(f"HTTP {exc.code}{': ' + text if text else ''}") from None
    except (urllib.error.URLError, OSError, ValueError) as exc:  # refused, unreachable, timeout, bad URL
        reason = exc.reason if isinstance(exc, urllib.error.URLError) else exc
        raise RemoteError(f"no answer: {reason or type(exc).__name__}") from None
    if len(body) > MAX_REPLY_BYTES:
        raise RemoteError(f"reply larger than {MAX_REPLY_BYTES} bytes")
    try:
        return json.loads(body)
    except ValueError:
        raise RemoteError(f"reply is not JSON: {body[:60]!r}") from None


def get_json(url: str, timeout: float) -> Any:
    """GET ``url`` and return its JSON (the management API's replies)."""
    return _request(url, timeout)


def _value(envelope: Any, member: str) -> Any:
    if not isinstance(envelope, dict):
        raise RemoteError(f"{member}: the reply is not an Alpaca envelope")
    number = envelope.get("ErrorNumber", 0)
    if number:
        number_text = f"0x{number:X}" if isinstance(number, int) else repr(number)
        raise RemoteError(f"{member}: error {number_text} {envelope.get('ErrorMessage', '')}".rstrip())
    return envelope.get("Value")


class RemoteDevice:
    """One Alpaca device by its URL (``http://host:port/api/v1/<type>/<number>``)."""

    def __init__(self, url: str, *, client_id: int, timeout: float) -> None:
        self.url = url.rstrip("/")
        self.client_id = client_id
        self.timeout = timeout

    def get(self, member: str) -> Any:
        """The member's ``Value``; raises RemoteError."""
        query = urllib.parse.urlencode({"ClientID": self.client_id, "ClientTransactionID": next(_transactions)})
        return _value(_request(f"{self.url}/{member}?{query}", self.timeout), member)

    def put(self, member: str, **params: Any) -> None:
        """PUT a member with form parameters (booleans as ``true``/``false``); raises RemoteError."""
        form = {name: str(value).lower() if isinstance(value, bool) else str(value) for name, value in params.items()}
        form.update(ClientID=str(self.client_id), ClientTransactionID=str(next(_transactions)))
        _value(_request(f"{self.url}/{member}", self.timeout, urllib.parse.urlencode(form).encode()), member)

    def get_bool(self, member: str) -> bool:
        value = self.get(member)
        if not isinstance(value, bool):
            raise RemoteError(f"{member}: expected true or false, got {json.dumps(value)[:40]}")
        return value

    def get_int(self, member: str) -> int:
        value = self.get(member)
        if isinstance(value, bool) or not isinstance(value, int):
            raise RemoteError(f"{member}: expected an integer, got {json.dumps(value)[:40]}")
        return value
