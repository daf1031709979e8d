"""The one Alpaca test client, at three levels over one keep-alive session.

- raw HTTP (``http_get``/``http_put`` and the ``_query``/``_body`` forms): exactly what the test
  passes, nothing added, a ``requests.Response`` back; for wire-level tests (casing, bad values).
- calls (``get``/``put``/``call``): ``ClientID`` and a fresh ``ClientTransactionID`` added, the reply
  decoded and timed into a :class:`Call`, optionally recorded in a :class:`CallLog`. A failure to
  get any answer is recorded too, never raised, so a hang is measured rather than cut short.
- asserting helpers (``value``/``command``/``device_state``): the call must succeed.

The limits a :class:`Call` is judged by come from what real clients tolerate
(``shared/alpaca/clients.md``): N.I.N.A.'s ASCOM client and PHD2's control connection give up
after 5 s, PHD2's status connection after 3 s, and a PulseGuide PUT gets its duration plus 5 s.
"""

from __future__ import annotations

import itertools
import threading
import time
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any

import requests

#: PHD2's status connection (clients.md §2.1): the strictest timeout any client puts on a GET.
GET_LIMIT_S = 3.0
#: N.I.N.A. (ASCOM .NET client, clients.md §0.1) and PHD2's control connection.
PUT_LIMIT_S = 5.0
#: PHD2 allows a PulseGuide PUT its duration plus this (clients.md §2.1).
PULSE_MARGIN_S = 5.0
#: How long a call may run before the test client itself gives up, so that a hang is measured
#: (and reported with its length) rather than cut off at a real client's limit.
HANG_CUTOFF_S = 40.0

#: Times in reports are shown relative to this (the test session's start).
EPOCH = time.monotonic()

_ctids = itertools.count(1)
_ctid_lock = threading.Lock()


def next_ctid() -> int:
    """A ClientTransactionID no other call in this test session has used."""
    with _ctid_lock:
        return next(_ctids)


def local_url(port: int, host: str = "127.0.0.1") -> str:
    return f"http://{host}:{port}"


@dataclass(frozen=True)
class Call:
    """One Alpaca request as the client saw it."""

    client_id: int
    verb: str
    member: str
    params: dict[str, Any]
    started: float  # time.monotonic() when sent
    elapsed: float
    status: int | None  # None: no HTTP answer at all
    ctid: int
    echoed_ctid: int | None
    error_number: int | None
    error_message: str
    value: Any
    exception: str = ""

    @property
    def ok(self) -> bool:
        return self.status == 200 and self.error_number == 0

    @property
    def limit(self) -> float:
        """How long the strictest real client waits for this request."""
        if self.verb == "GET":
            return GET_LIMIT_S
        if self.member == "pulseguide":
            return int(self.params.get("Duration", 0)) / 1000.0 + PULSE_MARGIN_S
        return PUT_LIMIT_S

    def describe(self) -> str:
        shown = ", ".join(f"{k}={v}" for k, v in self.params.items())
        outcome = self.exception or f"HTTP {self.status} err 0x{self.error_number or 0:X} {self.error_message!r}"
        return (f"{self.verb} {self.member}({shown}) by #{self.client_id} at t+{self.started - EPOCH:.2f}: "
                f"{outcome} in {self.elapsed:.3f} s")


def problems_of(call: Call, allowed: set[int]) -> list[str]:
    """What a real client would have seen go wrong with ``call`` (``allowed``: expected ASCOM errors)."""
    found = []
    if call.status is None:
        found.append(f"no HTTP answer: {call.describe()}")
    elif call.status != 200:
        found.append(f"HTTP {call.status}: {call.describe()}")
    elif call.echoed_ctid != call.ctid:
        found.append(f"ClientTransactionID {call.ctid} answered as {call.echoed_ctid}: {call.describe()}")
    elif call.error_number not in (0, *allowed):
        found.append(f"unexpected ASCOM error: {call.describe()}")
    if call.elapsed > call.limit:
        found.append(f"slower than the {call.limit:.1f} s clients wait: {call.describe()}")
    return found


class CallLog:
    """Every request any test client made, for the end-of-test health verdict.

    ``keep=False`` (the soak) keeps only counters and the problems found, judged as each call
    arrives against ``allowed_errors``, so the instrument itself does not grow with the run.
    """

    def __init__(self, *, keep: bool = True, allowed_errors: Iterable[int] = ()) -> None:
        self._calls: list[Call] = []
        self._lock = threading.Lock()
        self._keep = keep
        self._allowed = set(allowed_errors)
        self._problems: list[str] = []
        self.count = 0
        self.errors: dict[int, int] = {}
        self._slowest: dict[str, Call] = {}

    def add(self, call: Call) -> None:
        with self._lock:
            self.count += 1
            if call.error_number:
                self.errors[call.error_number] = self.errors.get(call.error_number, 0) + 1
            slowest = self._slowest.get(call.verb)
            if slowest is None or call.elapsed > slowest.elapsed:
                self._slowest[call.verb] = call
            if self._keep:
                self._calls.append(call)
            else:
                self._problems.extend(problems_of(call, self._allowed))

    def calls(self, since: float = 0.0, until: float = float("inf")) -> list[Call]:
        with self._lock:
            return [c for c in self._calls if since <= c.started <= until]

    def problems(self, *, since: float = 0.0, allowed_errors: Iterable[int] = ()) -> list[str]:
        """Protocol-level failures: no answer, 5xx or other non-200, CTID not echoed, slower than the clients allow.

        ``allowed_errors`` are ASCOM error numbers the scenario expects (a command refused during an
        outage is the right answer, not a protocol error); any other non-zero ErrorNumber is reported.
        """
        if not self._keep:
            with self._lock:
                return list(self._problems)
        allowed = set(allowed_errors)
        found: list[str] = []
        for call in self.calls(since):
            found.extend(problems_of(call, allowed))
        return found

    def slowest(self, verb: str) -> Call | None:
        with self._lock:
            return self._slowest.get(verb)


class AlpacaClient:
    """One Alpaca client (its own ClientID) on one telescope of a server.

    ``base`` is ``http://host:port``, or just the port of a server on 127.0.0.1.
    """

    def __init__(self, base: str | int, client_id: int = 4242, log: CallLog | None = None, *, device: int = 0,
                 auth: tuple[str, str] | None = None, timeout: float = 10.0,
                 call_timeout: float = HANG_CUTOFF_S) -> None:
        self.base = local_url(base) if isinstance(base, int) else base.rstrip("/")
        self.client_id = client_id
        self.device_number = device
        self.log = log if log is not None else CallLog()
        self.timeout = timeout  # raw requests
        self.call_timeout = call_timeout  # decoded calls: long, so a hang is measured
        self.session = requests.Session()
        if auth is not None:
            self.session.auth = auth

    def close(self) -> None:
        self.session.close()

    def url(self, member: str, number: int | None = None) -> str:
        """The member's URL, spelled exactly as given (wire tests need odd casing)."""
        return f"{self.base}/api/v1/telescope/{self.device_number if number is None else number}/{member}"

    # -- raw HTTP: nothing added -----------------------------------------------------------------

    def http_get(self, member: str, params: Mapping[str, Any] | None = None, **kw: Any) -> requests.Response:
        kw.setdefault("timeout", self.timeout)
        return self.session.get(self.url(member), params=params, **kw)

    def http_get_query(self, member: str, query: str, **kw: Any) -> requests.Response:
        """GET with the query string exactly as given (blank values, odd casing)."""
        kw.setdefault("timeout", self.timeout)
        return self.session.get(f"{self.url(member)}?{query}", **kw)

    def http_put(self, member: str, data: Mapping[str, Any] | None = None, **kw: Any) -> requests.Response:
        kw.setdefault("timeout", self.timeout)
        return self.session.put(self.url(member), data=data or {}, **kw)

    def http_put_body(self, member: str, body: str | bytes, **kw: Any) -> requests.Response:
        """PUT a form body exactly as given."""
        headers = {"Content-Type": "application/x-www-form-urlencoded", **kw.pop("headers", {})}
        kw.setdefault("timeout", self.timeout)
        return self.session.put(self.url(member), data=body, headers=headers, **kw)

    def send(self, verb: str, url: str, fields: Mapping[str, Any], timeout: float) -> requests.Response:
        """One request with ``fields`` as the query (GET) or the form body (PUT)."""
        if verb == "GET":
            return self.session.get(url, params=fields, timeout=timeout)
        return self.session.put(url, data=fields, timeout=timeout)

    # -- decoded, timed calls --------------------------------------------------------------------

    def call(self, verb: str, member: str, params: Mapping[str, Any]) -> Call:
        ctid = next_ctid()
        fields = {"ClientID": self.client_id, "ClientTransactionID": ctid, **params}
        started = time.monotonic()
        status = echoed = number = None
        message = exception = ""
        value: Any = None
        try:
            response = self.send(verb, self.url(member), fields, self.call_timeout)
            status = response.status_code
            if status == 200:
                body = response.json()
                echoed = body.get("ClientTransactionID")
                number = body.get("ErrorNumber")
                message = body.get("ErrorMessage") or ""
                value = body.get("Value")
            else:
                message = response.text[:200]
        except (requests.RequestException, ValueError) as exc:
            exception = f"{type(exc).__name__}: {exc}"
        call = Call(self.client_id, verb, member, dict(params), started, time.monotonic() - started, status, ctid,
                    echoed, number, message, value, exception)
        self.log.add(call)
        return call

    def get(self, member: str, **params: Any) -> Call:
        return self.call("GET", member, params)

    def put(self, member: str, **params: Any) -> Call:
        return self.call("PUT", member, params)

    # -- asserting helpers -----------------------------------------------------------------------

    def value(self, member: str, **params: Any) -> Any:
        """GET ``member``'s Value; the call must succeed."""
        call = self.get(member, **params)
        assert call.ok, call.describe()
        return call.value

    def command(self, member: str, **params: Any) -> Call:
        """PUT ``member``; the call must succeed."""
        call = self.put(member, **params)
        assert call.ok, call.describe()
        return call

    def device_state(self) -> dict[str, Any]:
        return {item["Name"]: item["Value"] for item in self.value("devicestate")}
