"""The mini-ConformU itself: its client and graders must catch what ConformU catches.

A clean run is only evidence if the harness would have complained about a broken server. These
tests feed the ConformU client, the alpyca adapter and both graders the replies checklist §1, §2
and §C single out, from a tiny scripted HTTP device, and check the outcome ConformU would log.
"""

from __future__ import annotations

import json
import threading
from collections.abc import Callable, Iterator
from datetime import datetime, timezone
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from urllib.parse import parse_qsl, urlsplit

import pytest

from tests.conformance.ascom import (
    AlpacaTelescope,
    AlpycaTelescope,
    DriverException,
    EmulatedClock,
    InvalidJsonDateTimeException,
    InvalidOperationException,
    InvalidValueException,
    NotImplementedException,
    ParkedException,
    ValueNotSetException,
    dotnet_double,
    utc_date_text,
)
from tests.conformance.conformu_base import DeviceTesterBase, MemberType, Required
from tests.conformance.conformu_protocol import ProtocolTester
from tests.conformance.report import Level, Report

Reply = tuple[int, str, str]  # status, content type, body


class FakeDevice:
    """An HTTP device whose reply to each (verb, member) is scripted; records every request."""

    def __init__(self) -> None:
        self.replies: dict[tuple[str, str], Callable[[dict[str, str]], Reply]] = {}
        self.requests: list[tuple[str, str, str]] = []  # verb, path, query or body
        device = self

        class Handler(BaseHTTPRequestHandler):
            def _serve(self, verb: str) -> None:
                parts = urlsplit(self.path)
                raw = parts.query if verb == "GET" else self.rfile.read(int(self.headers.get("Content-Length", 0)))
                text = raw if isinstance(raw, str) else raw.decode()
                device.requests.append((verb, parts.path, text))
                member = parts.path.rsplit("/", 1)[-1]
                script = device.replies.get((verb, member))
                status, ctype, body = script(dict(parse_qsl(text, keep_blank_values=True))) if script else \
                    (404, "text/plain", "no such member")
                payload = body.encode()
                self.send_response(status)
                if ctype:
                    self.send_header("Content-Type", ctype)
                self.send_header("Content-Length", str(len(payload)))
                self.end_headers()
                self.wfile.write(payload)

            def do_GET(self) -> None:
                self._serve("GET")

            def do_PUT(self) -> None:
                self._serve("PUT")

            def log_message(self, *args: object) -> None:
                pass

        self.server = ThreadingHTTPServer(("127.0.0.1", 0), Handler)
        self.port = self.server.server_address[1]
        threading.Thread(target=self.server.serve_forever, daemon=True).start()

    def json(self, verb: str, member: str, body: dict[str, object], ctype: str = "application/json") -> None:
        def reply(fields: dict[str, str]) -> Reply:
            full = {"ClientTransactionID": int(fields.get("ClientTransactionID", "0") or 0),
                    "ServerTransactionID": 1, "ErrorNumber": 0, "ErrorMessage": "", **body}
            return 200, ctype, json.dumps(full)

        self.replies[(verb, member)] = reply

    def raw(self, verb: str, member: str, status: int, ctype: str, body: str) -> None:
        self.replies[(verb, member)] = lambda fields: (status, ctype, body)


class RealClock:
    speed = 1.0

    def now(self) -> datetime:
        return datetime.now(timezone.utc)

    def seconds(self) -> float:
        import time

        return time.monotonic()


@pytest.fixture
def device() -> Iterator[FakeDevice]:
    fake = FakeDevice()
    yield fake
    fake.server.shutdown()


@pytest.fixture
def client(device: FakeDevice) -> AlpacaTelescope:
    return AlpacaTelescope("127.0.0.1", device.port, 0, EmulatedClock(RealClock()))


def test_requests_are_built_like_the_ascom_client(device: FakeDevice, client: AlpacaTelescope) -> None:
    device.json("PUT", "tracking", {})
    device.json("PUT", "utcdate", {})
    device.json("GET", "axisrates", {"Value": []})
    client.Tracking = True
    client.UTCDate = datetime(2024, 1, 31, 21, 5, 0, 123456, tzinfo=timezone.utc)
    client.AxisRates(1)
    (_, _, tracking), (_, _, utc), (_, path, query) = device.requests
    assert dict(parse_qsl(tracking))["Tracking"] == "True"
    assert dict(parse_qsl(utc))["UTCDate"] == "2024-01-31T21:05:00.1234560Z"
    assert path == "/api/v1/telescope/0/axisrates"
    assert query.startswith("ClientID=1&ClientTransactionID=")
    assert query.endswith("&Axis=1")


def test_dotnet_number_formatting() -> None:
    assert [dotnet_double(v) for v in (0.0, -301.0, 2385.0, 51.4769, 1e-05, 0.05 / 15)] == \
        ["0", "-301", "2385", "51.4769", "1E-05", "0.0033333333333333335"]
    assert utc_date_text(datetime(2016, 3, 4, 17, 45, 31, 123456, tzinfo=timezone.utc)) == \
        "2016-03-04T17:45:31.1234560Z"


def test_reply_rules(device: FakeDevice, client: AlpacaTelescope) -> None:
    device.json("GET", "canpark", {"Value": True}, ctype="text/plain")
    with pytest.raises(InvalidValueException, match="content type"):
        _ = client.CanPark
    device.json("GET", "canpark", {"Value": True, "ErrorMessage": None})
    with pytest.raises(DriverException):
        _ = client.CanPark
    device.raw("GET", "canpark", 200, "application/json",
               '{"Value": true, "errornumber": 1025, "errormessage": "miscased keys are no error"}')
    assert client.CanPark is True
    device.raw("GET", "canpark", 200, "application/json", '{"value": true, "ErrorNumber": 0, "ErrorMessage": ""}')
    assert client.CanPark is False  # a miscased Value reads as the default
    for number, cls in ((0x401, InvalidValueException), (0x402, ValueNotSetException), (0x408, ParkedException),
                        (0x40B, InvalidOperationException), (0x400, NotImplementedException)):
        device.json("GET", "targetdeclination", {"Value": None, "ErrorNumber": number, "ErrorMessage": "x"})
        with pytest.raises(cls):
            _ = client.TargetDeclination
    device.json("GET", "targetdeclination", {"Value": None, "ErrorNumber": 0x500, "ErrorMessage": "x"})
    with pytest.raises(DriverException) as info:
        _ = client.TargetDeclination
    assert type(info.value) is DriverException and info.value.number == 0x80040500
    device.raw("PUT", "park", 400, "text/plain", "bad request")
    with pytest.raises(DriverException, match="HTTP Completion Status: 400"):
        client.Park()
    device.json("GET", "utcdate", {"Value": "2024-01-31T21:05:00.1234567+00:00"})
    with pytest.raises(InvalidJsonDateTimeException):
        _ = client.UTCDate
    device.json("GET", "utcdate", {"Value": "2024-01-31T21:05:00.1234567Z"})
    assert client.UTCDate == datetime(2024, 1, 31, 21, 5, 0, 123456, tzinfo=timezone.utc)


def test_alpyca_replies_get_the_same_rules(device: FakeDevice) -> None:
    scope = AlpycaTelescope("127.0.0.1", device.port, 0)
    device.json("GET", "canpark", {"Value": True}, ctype="")
    with pytest.raises(InvalidValueException):
        _ = scope.CanPark
    device.json("GET", "canpark", {"Value": True, "ErrorMessage": "an error hidden behind ErrorNumber 0"})
    with pytest.raises(DriverException):
        _ = scope.CanPark
    device.json("PUT", "siteelevation", {"ErrorNumber": 0x408, "ErrorMessage": "parked"})
    with pytest.raises(ParkedException):
        scope.SiteElevation = 10.0
    device.json("GET", "axisrates", {"Value": [{"Minimum": 0.1, "Maximum": 2.0}]})
    assert scope.AxisRates(0) == [(0.1, 2.0)]


def test_grading_follows_conformu() -> None:
    report = Report("grading")
    grader = DeviceTesterBase(report, EmulatedClock(RealClock()))
    not_implemented = NotImplementedException("nope")
    grader.handle_exception("Optional", MemberType.PROPERTY, Required.OPTIONAL, not_implemented, "")
    grader.handle_exception("NotImpl", MemberType.METHOD, Required.MUST_NOT_BE_IMPLEMENTED, not_implemented, "x")
    assert report.issues == 0
    grader.handle_exception("Mandatory", MemberType.PROPERTY, Required.MANDATORY, not_implemented, "")
    assert report.issues == 1
    # 0x40B where 0x401 is expected: two ISSUEs (checklist §2).
    grader.handle_invalid_value_exception_as_ok("Bad", MemberType.METHOD, Required.MANDATORY,
                                                InvalidOperationException("wrong code"), "", "ok")
    assert report.issues == 3
    # Anything but a ParkedException while parked is a Conform ERROR.
    assert not grader.is_parked_exception(InvalidOperationException("not parked?"))
    assert report.errors == 1


def test_protocol_grading(device: FakeDevice) -> None:
    """Miscased keys, an echoed miscased form CTID and 200+0x401 for a miscased PUT name are caught."""
    report = Report("protocol")
    clock = EmulatedClock(RealClock())
    tester = ProtocolTester("127.0.0.1", device.port, AlpacaTelescope("127.0.0.1", device.port, 0, clock), clock,
                            report)

    def lenient(fields: dict[str, str]) -> Reply:  # case-insensitive form names, like a naive server
        lowered = {k.lower(): v for k, v in fields.items()}
        ctid = int(lowered.get("clienttransactionid", "0") or 0)
        if "tracking" in fields or "Tracking" in fields:
            return 200, "application/json", json.dumps({"ClientTransactionID": ctid, "ServerTransactionID": 7,
                                                        "ErrorNumber": 0, "ErrorMessage": ""})
        return 200, "application/json", json.dumps({"ClientTransactionID": ctid, "ServerTransactionID": 7,
                                                    "ErrorNumber": 0x401, "ErrorMessage": "missing Tracking"})

    device.replies[("PUT", "tracking")] = lenient
    tester.call_api("Bad casing", "Tracking", "PUT", [("ClientID", "1"), ("ClientTransactionID", "5"),
                                                       ("tRACKING", "True")], [400])
    assert report.issues == 1
    tester.call_api("Bad ClientTransactionID casing", "Tracking", "PUT",
                    [("ClientID", "1"), ("clienttransactionid", "67890"), ("Tracking", "True")], [200],
                    badly_cased_ctid=True)
    assert report.infos == 1
    device.raw("GET", "name", 200, "application/json",
               '{"Value": "x", "ClientTransactionID": 5, "ServerTransactionID": 1, "errorNumber": 0, '
               '"ErrorMessage": ""}')
    tester.call_api("Miscased key", "Name", "GET", [("ClientID", "1"), ("ClientTransactionID", "5")], [200])
    assert report.issues == 2
    assert report.findings(Level.ERROR) == []
