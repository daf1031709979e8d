"""Schemathesis against the official Alpaca OpenAPI files, run on a live alpaca-zwo server.

Shared by the CI test (``test_schemathesis.py``, a bounded number of examples) and the long run
(``long_run.py``, tens of thousands of requests), so both apply exactly the same checks. The schemas
and their few documented corrections are in ``spec_fixes.py``.

Every reply is checked with schemathesis' response-schema, status-code and content-type checks (and
its positive/negative data checks), plus the Alpaca rules the schema cannot express; any violation
fails the run. Two kinds of schemathesis finding are the protocol's own rule rather than a fault and
are counted as accepted deviations, each with its reason (:func:`accepted_deviation`).
"""

from __future__ import annotations

import contextlib
import json
import threading
import time
import zlib
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import requests
import schemathesis
from schemathesis import Case
from schemathesis.checks import not_a_server_error
from schemathesis.core.failures import AcceptedNegativeData, Failure, FailureGroup
from schemathesis.core.parameters import ParameterLocation
from schemathesis.specs.openapi.checks import (
    content_type_conformance,
    negative_data_rejection,
    positive_data_acceptance,
    response_schema_conformance,
    status_code_conformance,
)

from alpaca_zwo.alpaca.members import DEVICE_MEMBERS, routes
from alpaca_zwo.config.settings import EmulatorSettings, Settings
from alpaca_zwo.config.store import SettingsStore
from alpaca_zwo.server import AlpacaZwoServer
from tests.conftest import make_settings
from tests.fuzz.spec_fixes import UINT32_MAX
from tests.support import AlpacaClient, wait_until

#: The fuzzing harness keeps the telescope connected under this ClientID; generated requests use others.
KEEPER_CLIENT_ID = 3141592653
#: Emulator clock rate: slews take a fraction of a second, so motion members do real work quickly.
FUZZ_SPEED = 50.0
REQUEST_TIMEOUT_S = 60.0  # a synchronous slew may legitimately take a while; a hang must not be forever


# ================================================================================================
# Where a case goes: telescope 0, or deliberately a device this server does not have
# ================================================================================================

OTHER_TYPES = ("camera", "covercalibrator", "dome", "filterwheel", "focuser", "observingconditions", "rotator",
               "safetymonitor", "switch")


def pick_route(case: Case) -> str:
    """Most cases go to telescope 0, about one in five to a device number or type this server lacks.

    Derived from the generated path parameters (not drawn separately), because schemathesis cannot
    combine extra ``given`` strategies with the schema's own examples; the choice is still
    deterministic for a given case, so a failure replays exactly.
    """
    digest = zlib.crc32(repr(sorted(case.path_parameters.items())).encode()) % 10
    return {0: "other-number", 1: "other-type"}.get(digest, "telescope0")


def route_case(case: Case, route: str) -> str:
    """Point a case at telescope 0 (or at an absent device) unless its path is the generated mistake.

    Returns what the request is now: "telescope0", "absent-device" (valid per the schema, but not
    on this server: the spec's documented 400), or "negative-path" (left as generated: invalid).
    """
    meta = case.meta
    if meta is not None and meta.is_negative_at(ParameterLocation.PATH):
        return "negative-path"
    params = case.path_parameters
    has_type = "device_type" in params
    if route == "telescope0" or (route == "other-type" and not has_type):
        params["device_number"] = 0
        if has_type:
            params["device_type"] = "telescope"
        return "telescope0"
    if route == "other-number":
        number = params.get("device_number")
        params["device_number"] = number if isinstance(number, int) and number > 0 else 1
        if has_type:
            params["device_type"] = "telescope"
    else:
        kind = params.get("device_type")
        params["device_type"] = kind if kind in OTHER_TYPES else "camera"
        params["device_number"] = 0
    return "absent-device"


# ================================================================================================
# Checks: the spec's (through schemathesis) plus the Alpaca rules the spec cannot express
# ================================================================================================


#: {verb: {path element: Member}} of the telescope, to know which replies carry a Value.
MEMBER_ROUTES = routes(DEVICE_MEMBERS["telescope"])


class AlpacaViolation(AssertionError):
    """A reply that breaks an Alpaca rule the OpenAPI file cannot express."""


def _sent_field(case: Case, name: str) -> object:
    container = case.query if case.method.upper() == "GET" else case.body
    if isinstance(container, dict):
        return container.get(name)
    return None


def _check_status(case: Case, status: int, content_type: str, kind: str, where: str) -> bool:
    """Status rules (Reference §2.5); True when the reply is a 200 JSON body still to be checked."""
    if case.method.upper() not in ("GET", "PUT"):
        # Verbs the spec does not define (schemathesis tries them): refused, or OPTIONS answered for CORS.
        if not (status in (400, 405) or (case.method.upper() == "OPTIONS" and status == 200)):
            raise AlpacaViolation(f"{where}: an undefined verb must be refused (400/405), got {status}")
        return False
    setup_page = case.path.startswith("/setup")
    if kind == "absent-device":
        wanted = 403 if setup_page else 400  # Management API: 403; Device API: 400 (Reference §2.5.2)
        if status != wanted:
            raise AlpacaViolation(f"{where}: a device this server does not have must answer {wanted}, got {status}")
    if status != 200:
        if not content_type.startswith("text/"):
            raise AlpacaViolation(f"{where}: HTTP {status} must carry a text message, got {content_type!r}")
        return False
    if setup_page:
        if not content_type.startswith("text/html"):
            raise AlpacaViolation(f"{where}: a setup page must be text/html, got {content_type!r}")
        return False
    if not content_type.startswith("application/json"):
        raise AlpacaViolation(f"{where}: 200 without application/json ({content_type!r})")
    return True


def _check_value(case: Case, body: dict[str, Any], number: object, where: str) -> None:
    """``Value`` rules (protocol-rules §6): typed and non-null whenever the member returns one."""
    if case.path.startswith("/management"):
        if body.get("Value") is None:
            raise AlpacaViolation(f"{where}: a management reply needs a Value")
        return
    if number == 0 and "Value" in body and body["Value"] is None:
        raise AlpacaViolation(f"{where}: success with a null Value")
    member = MEMBER_ROUTES.get(case.method.upper(), {}).get(case.path.rsplit("/", 1)[-1])
    if member is None:
        return
    # A value-returning member carries its Value on errors too (the type's default); a method never does.
    if member.returns is None and "Value" in body:
        raise AlpacaViolation(f"{where}: a method reply must not carry a Value")
    if member.returns is not None and body.get("Value") is None:
        raise AlpacaViolation(f"{where}: reply (ErrorNumber {number}) without a non-null Value")


def alpaca_checks(case: Case, response: Any, kind: str) -> None:
    """Envelope rules (R1) and status rules (Reference §2.5): raise AlpacaViolation when broken."""
    content_type = response.headers.get("content-type", [""])
    content_type = content_type[0] if isinstance(content_type, list) else content_type
    where = f"{case.method.upper()} {case.formatted_path}"
    if not _check_status(case, response.status_code, content_type, kind, where):
        return
    try:
        body = json.loads(response.content)
    except ValueError:
        raise AlpacaViolation(f"{where}: 200 with a body that is not JSON: {response.content[:200]!r}") from None
    number, message = body.get("ErrorNumber"), body.get("ErrorMessage")
    if case.path.startswith("/management"):
        number, message = body.get("ErrorNumber", 0), body.get("ErrorMessage", "")  # optional extras there
    if (number == 0) != (message == ""):
        raise AlpacaViolation(f"{where}: ErrorNumber {number} with ErrorMessage {message!r}")
    _check_value(case, body, number, where)
    sent = _sent_field(case, "ClientTransactionID")
    valid_id = isinstance(sent, int) and not isinstance(sent, bool) and 0 <= sent <= UINT32_MAX
    if valid_id and body.get("ClientTransactionID") != sent:
        raise AlpacaViolation(f"{where}: sent ClientTransactionID {sent}, echoed {body.get('ClientTransactionID')}")


#: Why a schemathesis finding is not a server fault here (counted, never silently dropped).
RANGE_AS_ASCOM_ERROR = ("out-of-range value refused the Alpaca way: HTTP 200 with ErrorNumber 0x401 "
                        "(or 0x400 for a member the mount lacks), Reference §2.8; the schema's min/max are "
                        "ASCOM value ranges, not HTTP well-formedness")
EXTRA_PARAMETERS_TOLERATED = ("unknown extra parameters accepted: Alpaca devices must not fail on unrecognised "
                              "parameters (Reference §1.7 robustness principle, clients.md R2)")


def accepted_deviation(failure: BaseException, response: Any) -> str | None:
    """The documented reason a failure is the protocol's rule rather than a bug, or None."""
    if not isinstance(failure, AcceptedNegativeData):
        return None
    text = str(failure)
    invalid = [line for line in text.splitlines() if "Invalid component" in line or line.lstrip().startswith("- ")]
    if invalid and all("unexpected properties" in line or line.rstrip().endswith(":") for line in invalid):
        return EXTRA_PARAMETERS_TOLERATED
    if response.status_code == 200:
        try:
            number = json.loads(response.content).get("ErrorNumber")
        except ValueError:
            return None
        if number in (0x400, 0x401):
            return RANGE_AS_ASCOM_ERROR
    return None


SCHEMA_CHECKS = [not_a_server_error, status_code_conformance, content_type_conformance,
                 response_schema_conformance, negative_data_rejection, positive_data_acceptance]


@dataclass
class Stats:
    """What a run did, for the CI assertion and the long-run summary."""

    requests: int = 0
    statuses: Counter[int] = field(default_factory=Counter)
    ascom_errors: Counter[int] = field(default_factory=Counter)
    kinds: Counter[str] = field(default_factory=Counter)
    operations: Counter[str] = field(default_factory=Counter)
    problems: Counter[str] = field(default_factory=Counter)
    deviations: Counter[str] = field(default_factory=Counter)
    driver_errors: Counter[str] = field(default_factory=Counter)
    examples: dict[str, str] = field(default_factory=dict)
    max_latency_s: float = 0.0
    lock: threading.Lock = field(default_factory=threading.Lock, repr=False)

    def record_problem(self, key: str, detail: str) -> None:
        with self.lock:
            self.problems[key] += 1
            self.examples.setdefault(key, detail)

    def summary(self) -> dict[str, Any]:
        return {
            "requests": self.requests,
            "statuses": dict(sorted(self.statuses.items())),
            "ascom_errors": {f"0x{k:X}": v for k, v in sorted(self.ascom_errors.items())},
            "routes": dict(self.kinds),
            "method_paths": len(self.operations),
            "max_latency_s": round(self.max_latency_s, 3),
            "accepted_deviations": dict(self.deviations),
            "driver_errors": dict(self.driver_errors.most_common()),
            "problems": dict(self.problems),
            "problem_examples": self.examples,
        }


def describe_case(case: Case) -> str:
    body = case.body if not isinstance(case.body, type(schemathesis.core.NOT_SET)) else None
    return (f"{case.method.upper()} {case.formatted_path} query={case.query!r} body={body!r} "
            f"mode={case.meta.generation.mode.value if case.meta else '?'}")


def exercise(case: Case, base_url: str, session: requests.Session, stats: Stats) -> list[str]:
    """Send one case, run every check, and return the problems found (empty: all good)."""
    kind = route_case(case, pick_route(case))
    started = time.monotonic()
    try:
        response = case.call(base_url=base_url, session=session, timeout=REQUEST_TIMEOUT_S)
    except requests.RequestException as exc:
        problem = f"no reply: {type(exc).__name__}: {exc}"
        stats.record_problem("no reply", f"{describe_case(case)}: {problem}")
        return [problem]
    elapsed = time.monotonic() - started
    with stats.lock:
        stats.requests += 1
        stats.statuses[response.status_code] += 1
        stats.kinds[kind] += 1
        stats.operations[f"{case.method.upper()} {case.path}"] += 1
        stats.max_latency_s = max(stats.max_latency_s, elapsed)
        if response.status_code == 200:
            with contextlib.suppress(ValueError, AttributeError, TypeError):
                body = json.loads(response.content)
                number = int(body.get("ErrorNumber", -1))
                stats.ascom_errors[number] += 1
                if number >= 0x500:  # driver errors: worth reading even when nothing is "wrong"
                    stats.driver_errors[f"{case.method.upper()} {case.path}: {body.get('ErrorMessage', '')[:90]}"] += 1
    problems = []
    excluded = [positive_data_acceptance] if kind == "absent-device" else []
    try:
        case.validate_response(response, checks=[c for c in SCHEMA_CHECKS if c not in excluded])
    except (FailureGroup, Failure) as exc:
        failures = list(exc.exceptions) if isinstance(exc, FailureGroup) else [exc]
        for failure in failures:
            reason = accepted_deviation(failure, response)
            title = f"{failure.code} {failure.title}" if hasattr(failure, "code") else type(failure).__name__
            key = f"{case.method.upper()} {case.path}: {title}"
            if reason is not None:
                with stats.lock:
                    stats.deviations[reason] += 1
                continue
            detail = (f"{describe_case(case)} -> {response.status_code} {response.content[:300]!r}\n"
                      f"{str(failure).strip()[:1500]}")
            stats.record_problem(f"schema: {key}", detail)
            problems.append(f"schema: {key}\n{detail}")
    try:
        alpaca_checks(case, response, kind)
    except AlpacaViolation as exc:
        key = f"alpaca: {case.method.upper()} {case.path}: {str(exc).split(':', 1)[-1].strip()[:80]}"
        stats.record_problem(key, f"{describe_case(case)} -> {response.status_code} {response.content[:300]!r}")
        problems.append(str(exc))
    return problems


# ================================================================================================
# The live server and its keeper client
# ================================================================================================


def fuzz_settings() -> Settings:
    settings = make_settings(emulator=EmulatorSettings(speed=FUZZ_SPEED, baud=0))
    assert (settings.site.latitude, settings.site.longitude, settings.site.elevation) == SITE
    return settings


SITE = (51.4769, -0.0005, 46.0)


class Keeper(AlpacaClient):
    """The harness's own client: keeps the telescope connected and the run bounded and meaningful.

    Generated requests may park the mount, set a one-hour SlewSettleTime or leave an axis moving;
    that is exercised, then undone here so later cases still do real work in bounded time.
    """

    def __init__(self, base_url: str) -> None:
        super().__init__(base_url, KEEPER_CLIENT_ID, timeout=REQUEST_TIMEOUT_S, call_timeout=REQUEST_TIMEOUT_S)
        self.parks = 0

    def _put(self, member: str, **fields: object) -> dict[str, Any]:
        response = self.http_put(member, {"ClientID": str(KEEPER_CLIENT_ID), **{k: str(v) for k, v in fields.items()}})
        response.raise_for_status()
        return dict(response.json())

    def connect(self) -> None:
        reply = self._put("connected", Connected="true")
        assert reply["ErrorNumber"] == 0, reply

    def after(self, case: Case) -> None:
        path = case.path.rsplit("/", 1)[-1]
        if case.method.upper() != "PUT":
            return
        if path in ("connected", "disconnect", "connect"):
            self.connect()  # cheap and idempotent: the keeper's own connection is never at risk
        elif path == "slewsettletime":
            self._put("slewsettletime", SlewSettleTime=0)
        elif path == "park":
            self.parks += 1
            if self.parks % 4:  # most of the time unpark, so motion members keep doing real work
                self._put("unpark")

    def check_state(self) -> dict[str, Any]:
        """Mid-run invariant: DeviceState answers, with every name, the right types and sane ranges."""
        state = {item["Name"]: item["Value"] for item in self.value("devicestate")}
        assert STATE_NAMES <= state.keys() <= STATE_NAMES | {"TimeStamp"}, state
        for name in ("AtHome", "AtPark", "IsPulseGuiding", "Slewing", "Tracking"):
            assert isinstance(state[name], bool), (name, state[name])
        for name in ("Altitude", "Azimuth", "Declination", "RightAscension", "SiderealTime"):
            assert isinstance(state[name], float), (name, state[name])
        assert 0.0 <= state["RightAscension"] < 24.0 and -90.0 <= state["Declination"] <= 90.0, state
        assert 0.0 <= state["SiderealTime"] < 24.0 and -90.0 <= state["Altitude"] <= 90.0, state
        assert 0.0 <= state["Azimuth"] <= 360.0 and state["SideOfPier"] in (-1, 0, 1), state
        assert not (state["AtPark"] and state["Slewing"] and not self.value("slewing")), state
        return state

    def settle(self, timeout: float = 60.0) -> dict[str, Any]:
        """Stop everything and wait for a coherent, idle mount; return its DeviceState."""
        self.connect()
        if self.value("atpark"):
            self._put("unpark")
        self._put("slewsettletime", SlewSettleTime=0)
        reply = self._put("abortslew")
        assert reply["ErrorNumber"] == 0, reply
        wait_until(lambda: not (self.value("slewing") or self.value("ispulseguiding")), timeout,
                   "the mount to come to rest after AbortSlew")
        return {item["Name"]: item["Value"] for item in self.value("devicestate")}


def _wait_idle(keeper: Keeper, timeout: float = 60.0) -> None:
    wait_until(lambda: not keeper.value("slewing"), timeout, "a motion to end", interval=0.02)


def check_consistent(live: LiveServer) -> dict[str, Any]:
    """After fuzzing: the server still serves, the state hangs together, and a real session still works.

    The fuzzing left the site, clock and position wherever the last cases put them, so the session
    first restores what a client would set on connect (site, UTC time), homes the mount, then
    tracks and GOTOs to a target, checking Slewing, arrival and the read-back position.
    """
    keeper, site = live.keeper, live.site
    keeper.settle()
    state = keeper.check_state()
    assert state["Slewing"] is False and state["IsPulseGuiding"] is False and state["AtPark"] is False
    for name in ("AtHome", "AtPark", "Slewing", "Tracking"):
        assert keeper.value(name.lower()) == state[name], name
    assert keeper.value("connected") is True

    for member, value in (("sitelatitude", site[0]), ("sitelongitude", site[1]), ("siteelevation", site[2])):
        reply = keeper._put(member, **{KEEPER_NAMES[member]: value})
        assert reply["ErrorNumber"] == 0 and keeper.value(member) == value, (member, reply)
    now = time.strftime("%Y-%m-%dT%H:%M:%S.0000000Z", time.gmtime())
    reply = keeper._put("utcdate", UTCDate=now)
    assert reply["ErrorNumber"] == 0, reply
    assert keeper._put("findhome")["ErrorNumber"] == 0
    _wait_idle(keeper)
    home = keeper.check_state()
    # At the pole plus the sub-arcsecond remainder a fuzzed fine sync leaves in every reading (whether one
    # is accepted depends on timing; CI once read 89.99996513°, 0.13″ off, with AtHome true).
    pole = live.server.telescopes[0].mount.sync_remainder.to_sky(0.0, 90.0)[1]
    assert home["AtHome"] is True and abs(home["Declination"] - pole) < 1e-6, (pole, home)
    reply = keeper._put("tracking", Tracking="true")
    assert reply["ErrorNumber"] == 0, reply
    ra, dec = (keeper.value("siderealtime") + 2.0) % 24.0, 40.0  # HA -2 h: well above the horizon
    reply = keeper._put("slewtocoordinatesasync", RightAscension=ra, Declination=dec)
    assert reply["ErrorNumber"] == 0, reply
    assert keeper.value("slewing") is True
    _wait_idle(keeper)
    here = keeper.check_state()
    assert abs((here["RightAscension"] - ra + 12.0) % 24.0 - 12.0) < 5.0 / 3600.0, (here, ra)
    assert abs(here["Declination"] - dec) < 5.0 / 3600.0, (here, dec)
    assert here["Tracking"] is True and here["SideOfPier"] == 1 and here["AtHome"] is False
    for path in ("/management/apiversions", "/management/v1/description", "/management/v1/configureddevices"):
        assert requests.get(live.base_url + path, timeout=10).status_code == 200, path
    return here


KEEPER_NAMES = {"sitelatitude": "SiteLatitude", "sitelongitude": "SiteLongitude", "siteelevation": "SiteElevation"}


STATE_NAMES = frozenset({"Altitude", "AtHome", "AtPark", "Azimuth", "Declination", "IsPulseGuiding",
                         "RightAscension", "SideOfPier", "SiderealTime", "Slewing", "Tracking", "UTCDate"})


@dataclass
class LiveServer:
    server: AlpacaZwoServer
    base_url: str
    keeper: Keeper

    @property
    def site(self) -> tuple[float, float, float]:
        """The site the server started with, restored by :func:`check_consistent`."""
        return SITE


def start_live_server(config_path: Path) -> LiveServer:
    from alpaca_zwo.web import setup_routes

    store = SettingsStore(fuzz_settings(), config_path)
    server = AlpacaZwoServer(store, extra_routes_factory=setup_routes)
    server.start()
    base_url = f"http://127.0.0.1:{server.port}"
    keeper = Keeper(base_url)
    keeper.connect()
    return LiveServer(server, base_url, keeper)
