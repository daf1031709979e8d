"""What the telescope tests share: a strict Alpaca client, the error-table runner, and motion helpers.

These tests are the contract a client sees. They talk HTTP only (``requests`` and the ASCOM
Initiative's ``alpyca``) and look at the emulator solely to confirm that what the server reports is
what the mount physically did. :class:`Api` checks every reply's envelope against the member table
(``alpaca_zwo/alpaca/members.py``); :func:`run_cases` runs an error table through ``requests`` or
``alpyca`` and reports every wrong row at once.

The emulator runs ten times faster than real time (``SPEED``) so slews take a second or two; every
duration a client sends (pulse lengths, UTCDate) is mount time, measured on the emulator's clock.
All waits are bounded polls of a condition; nothing sleeps in place of synchronisation.
"""

from __future__ import annotations

import itertools
import math
import re
import time
import types
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from datetime import datetime, timezone
from typing import Any

import erfa
import requests
from alpaca import exceptions as alpyca_exceptions
from alpaca import telescope as alpyca_telescope

from alpaca_zwo.alpaca.members import DEVICE_MEMBERS, Member
from alpaca_zwo.config.settings import EmulatorSettings, Settings
from alpaca_zwo.emulator import MountModel
from alpaca_zwo.server import AlpacaZwoServer
from tests.conftest import make_settings
from tests.support import AlpacaClient, wait_until

SPEED = 10.0  # emulator clock rate: mount seconds per real second
ARCSEC = 1.0 / 3600.0
MOTION_TIMEOUT_S = 40.0  # real seconds; the longest slew at SPEED is a few seconds

OK = 0
NOT_IMPLEMENTED = 0x400
INVALID_VALUE = 0x401
VALUE_NOT_SET = 0x402
NOT_CONNECTED = 0x407
PARKED = 0x408
INVALID_OPERATION = 0x40B
ACTION_NOT_IMPLEMENTED = 0x40C

MEMBERS: dict[tuple[str, str], Member] = {(m.verb, m.name): m for m in DEVICE_MEMBERS["telescope"]}
ENVELOPE_KEYS = {"ClientTransactionID", "ServerTransactionID", "ErrorNumber", "ErrorMessage"}
UTC_DATE_RE = re.compile(r"^\d{4}-\d{2}-\d{2}T\d{2}:\d{2}:\d{2}(\.\d{1,7})?Z$")


def wire(value: object) -> str:
    """Format a value the way ASCOM's own clients put it on the wire (``True``, full-precision floats)."""
    if isinstance(value, bool):
        return "True" if value else "False"
    if isinstance(value, float):
        return repr(value)
    if isinstance(value, datetime):
        return value.astimezone(timezone.utc).strftime("%Y-%m-%dT%H:%M:%S.%fZ")
    return str(value)


def wrap12(hours: float) -> float:
    return (hours + 12.0) % 24.0 - 12.0


def parse_utc(text: str) -> datetime:
    """ISO 8601 with Z and up to seven fractional digits, as the server sends it."""
    assert UTC_DATE_RE.match(text), f"UTCDate {text!r} is not ISO 8601 UTC with Z"
    main, _, fraction = text[:-1].partition(".")
    micro = int((fraction or "0").ljust(6, "0")[:6])
    return datetime.strptime(main, "%Y-%m-%dT%H:%M:%S").replace(microsecond=micro, tzinfo=timezone.utc)


def mean_lst(utc: datetime, east_longitude_deg: float) -> float:
    """Local mean sidereal time from pyerfa (IAU 2006), independent of the project's own sky.py."""
    jd_utc = utc.timestamp() / 86400.0 + 2440587.5
    day, fraction = divmod(jd_utc, 1.0)
    gmst = erfa.gmst06(day, fraction, day, fraction + 69.184 / 86400.0)  # UT1 ~ UTC, TT = UTC + 69.184 s
    return (math.degrees(gmst) / 15.0 + east_longitude_deg / 15.0) % 24.0


@dataclass
class Reply:
    """One decoded Alpaca reply."""

    body: dict[str, Any]

    @property
    def error(self) -> int:
        return int(self.body["ErrorNumber"])

    @property
    def value(self) -> Any:
        assert self.error == OK, f"expected success, got 0x{self.error:X}: {self.body['ErrorMessage']}"
        return self.body["Value"]


class Api(AlpacaClient):
    """The shared Alpaca client, strict: every reply's envelope is checked against the member table.

    Members are named as ASCOM spells them (``RightAscension``); the path is derived, lower case.
    """

    def __init__(self, base_url: str, device: int = 0, client_id: int = 4242) -> None:
        super().__init__(base_url, client_id, device=device)
        self._ctid = itertools.count(1)
        self.exercised: set[tuple[str, str]] = set()

    def url(self, member: str, number: int | None = None) -> str:
        return super().url(member.lower(), number)

    def request(self, verb: str, name: str, params: Mapping[str, object] | None = None,
                timeout: float = 30.0) -> Reply:
        member = MEMBERS[(verb, name)]
        ctid = next(self._ctid)
        fields = {"ClientID": str(self.client_id), "ClientTransactionID": str(ctid)}
        fields.update({key: wire(value) for key, value in (params or {}).items()})
        response = self.send(verb, self.url(name), fields, timeout)
        self.exercised.add((verb, name))
        assert response.status_code == 200, f"{verb} {name} {params}: HTTP {response.status_code} {response.text}"
        assert response.headers["Content-Type"].startswith("application/json"), response.headers
        body = response.json()
        check_envelope(body, ctid, member)
        return Reply(body)

    def get(self, name: str, **params: object) -> Reply:
        return self.request("GET", name, params)

    def put(self, name: str, **params: object) -> Reply:
        return self.request("PUT", name, params)

    def value(self, name: str, **params: object) -> Any:
        return self.get(name, **params).value

    def ok(self, name: str, **params: object) -> None:
        reply = self.put(name, **params)
        assert reply.error == OK, f"PUT {name} {params}: 0x{reply.error:X} {reply.body['ErrorMessage']}"

    def state(self) -> dict[str, Any]:
        return {item["Name"]: item["Value"] for item in self.value("DeviceState")}

    def connect(self) -> Api:
        self.ok("Connected", Connected=True)
        return self

    def wait_idle(self, timeout: float = MOTION_TIMEOUT_S) -> None:
        wait_until(lambda: self.value("Slewing") is False, timeout, "Slewing to become false")

    def ra_at_ha(self, ha_hours: float) -> float:
        return (self.value("SiderealTime") - ha_hours) % 24.0

    def hour_angle(self) -> float:
        state = self.state()
        return wrap12(state["SiderealTime"] - state["RightAscension"])


def check_envelope(body: dict[str, Any], ctid: int, member: Member) -> None:
    """R1: exact key casing, ClientTransactionID echoed, ErrorMessage "" exactly when ErrorNumber is 0."""
    assert body.keys() >= ENVELOPE_KEYS, body
    assert body.keys() <= ENVELOPE_KEYS | {"Value"}, body
    assert body["ClientTransactionID"] == ctid, body
    assert isinstance(body["ServerTransactionID"], int) and body["ServerTransactionID"] >= 1, body
    assert isinstance(body["ErrorNumber"], int) and isinstance(body["ErrorMessage"], str), body
    if body["ErrorNumber"] == 0:
        assert body["ErrorMessage"] == "", body
        if member.returns is not None:
            assert "Value" in body, body
        else:
            assert "Value" not in body, f"a MethodResponse carries no Value: {body}"
    else:
        assert 0x400 <= body["ErrorNumber"] <= 0xFFF, body
        assert body["ErrorMessage"], f"an error needs a message: {body}"


# --- the same calls through alpyca, so the error tables run through the official client too ---

_ALPYCA_ERRORS = (
    alpyca_exceptions.ActionNotImplementedException,
    alpyca_exceptions.DriverException,
    alpyca_exceptions.InvalidOperationException,
    alpyca_exceptions.InvalidValueException,
    alpyca_exceptions.NotConnectedException,
    alpyca_exceptions.NotImplementedException,
    alpyca_exceptions.ParkedException,
    alpyca_exceptions.SlavedException,
    alpyca_exceptions.ValueNotSetException,
)


_ALPYCA_ENUMS: dict[str, Any] = {
    "Axis": alpyca_telescope.TelescopeAxes,
    "Direction": alpyca_telescope.GuideDirections,
    "SideOfPier": alpyca_telescope.PierSide,
    "TrackingRate": alpyca_telescope.DriveRates,
}


def _alpyca_arg(name: str, value: object) -> object:
    """alpyca takes enums and sends ``.value``; an out-of-range number travels in a stand-in with ``.value``."""
    enum = _ALPYCA_ENUMS.get(name)
    if enum is None:
        return value
    try:
        return enum(value)
    except ValueError:
        return types.SimpleNamespace(value=value)


#: Members alpyca answers with NotImplementedException without asking the server.
_ALPYCA_CLIENT_SIDE_REFUSED = {"SlewToCoordinates", "SlewToTarget", "SlewToAltAz"}


class Transport:
    """Runs one (verb, member, args) and returns the ASCOM error number (0 = success)."""

    name = "?"

    def call(self, verb: str, name: str, args: Mapping[str, object]) -> int:
        raise NotImplementedError


class RequestsTransport(Transport):
    name = "requests"

    def __init__(self, api: Api) -> None:
        self.api = api

    def call(self, verb: str, name: str, args: Mapping[str, object]) -> int:
        return self.api.request(verb, name, args).error


class AlpycaTransport(Transport):
    name = "alpyca"

    def __init__(self, port: int, device: int = 0) -> None:
        self.scope = alpyca_telescope.Telescope(f"127.0.0.1:{port}", device)

    def call(self, verb: str, name: str, args: Mapping[str, object]) -> int:
        member = MEMBERS[(verb, name)]
        try:
            if verb == "GET" and not member.params:
                getattr(self.scope, name)
            elif member.setter:
                setattr(self.scope, name, _alpyca_arg(name, args[name]))
            elif name == "Action":
                self.scope.Action(args["Action"])
            elif name in _ALPYCA_CLIENT_SIDE_REFUSED:
                # alpyca refuses the deprecated synchronous slews itself ("not available via Alpaca"),
                # so send them through its own request path to still get its reply handling.
                self.scope._put(name.lower(), **{p.name: args[p.name] for p in member.params})
            else:
                getattr(self.scope, name)(*(_alpyca_arg(p.name, args[p.name]) for p in member.params))
        except _ALPYCA_ERRORS as exc:
            return int(exc.number)
        return OK


@dataclass(frozen=True)
class Case:
    """One row of an error table: a call and the error numbers it may answer."""

    verb: str
    name: str
    args: Mapping[str, object]
    expect: frozenset[int]

    def __str__(self) -> str:
        shown = ", ".join(f"{k}={v!r}" for k, v in self.args.items())
        codes = "/".join(f"0x{c:X}" if c else "0" for c in sorted(self.expect))
        return f"{self.verb} {self.name}({shown}) -> {codes}"


def case(verb: str, name: str, expect: int | Sequence[int], **args: object) -> Case:
    assert (verb, name) in MEMBERS, f"no member {verb} {name}"
    codes = frozenset([expect] if isinstance(expect, int) else expect)
    return Case(verb, name, args, codes)


def run_cases(transport: Transport, cases: Sequence[Case],
              after: Callable[[Case], str | None] | None = None) -> None:
    """Run every case, then fail once listing every mismatch (one broken member must not hide the rest)."""
    problems = []
    for c in cases:
        got = transport.call(c.verb, c.name, c.args)
        if got not in c.expect:
            problems.append(f"{c}: got {f'0x{got:X}' if got else 'success'}")
        if after is not None and (trouble := after(c)):
            problems.append(f"{c}: {trouble}")
    assert not problems, f"{len(problems)} of {len(cases)} cases wrong via {transport.name}:\n  " + "\n  ".join(
        problems)


def assert_400(response: requests.Response, why: str) -> None:
    assert response.status_code == 400, f"{why}: HTTP {response.status_code} {response.text!r}"
    assert response.headers["Content-Type"].startswith("text/plain"), f"{why}: {response.headers}"
    assert response.text.strip(), why


def fast_settings(**sections: Any) -> Settings:
    return make_settings(emulator=EmulatorSettings(speed=SPEED, baud=0), **sections)


def make_transport(kind: str, server: AlpacaZwoServer, api: Api) -> Transport:
    return RequestsTransport(api) if kind == "requests" else AlpycaTransport(server.port)


def mount_seconds(server: AlpacaZwoServer, index: int = 0) -> float:
    emulator = server.emulators[index]
    assert emulator is not None
    return emulator.clock.seconds()


def slew_to_ha(api: Api, ha_hours: float, dec: float) -> tuple[float, float]:
    """Synchronous-in-effect GOTO to an hour angle; returns the (RA, Dec) commanded."""
    ra = api.ra_at_ha(ha_hours)
    api.ok("SlewToCoordinatesAsync", RightAscension=ra, Declination=dec)
    api.wait_idle()
    return ra, dec


def watch_slewing(api: Api, server: AlpacaZwoServer, model: MountModel, start: Callable[[], None],
                  timeout: float = MOTION_TIMEOUT_S) -> list[bool]:
    """Start a motion, then poll Slewing as fast as possible until it reads false.

    Asserts the first read after the call returned is true, and that when Slewing first reads false
    the mount really is at rest (the emulator's own GOTO has finished). Returns the reads.
    """
    start()
    reads = [api.value("Slewing")]
    assert reads[0] is True, "Slewing must already be true when the asynchronous call returns"
    deadline = time.monotonic() + timeout
    while reads[-1]:
        assert time.monotonic() < deadline, "the motion did not end"
        reads.append(api.value("Slewing"))
    assert not model.slewing(), "Slewing read false while the mount was still slewing"
    assert model.pulsing() == (False, False)
    # ... and it stays false: no flicker back to true once the motion has ended.
    until = mount_seconds(server) + 3.0
    while mount_seconds(server) < until:
        assert api.value("Slewing") is False, "Slewing flickered back to true after the motion ended"
    return reads


def assert_at(api: Api, ra: float, dec: float, tolerance_arcsec: float = 2.0) -> None:
    state = api.state()
    dra = abs(wrap12(state["RightAscension"] - ra)) * 15.0 * 3600.0 * math.cos(math.radians(dec))
    ddec = abs(state["Declination"] - dec) * 3600.0
    assert dra <= tolerance_arcsec and ddec <= tolerance_arcsec, (
        f"at RA {state['RightAscension']:.6f} Dec {state['Declination']:.6f}, expected {ra:.6f} {dec:.6f} "
        f"(off by {dra:.1f}\" / {ddec:.1f}\")")
