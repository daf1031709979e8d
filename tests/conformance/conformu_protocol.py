"""ConformU's ``alpacaprotocol`` suite (checklist §C): raw HTTP requests and their grading.

This suite ignores ASCOM semantics: it sends each member with good IDs, an extra parameter,
lower-cased ``clientid`` / ``clienttransactionid``, a bad parameter value, a case-inverted parameter
name and eight bad ID values, and grades the HTTP status, the JSON shape and the transaction IDs
(``SendToDevice``, APT L2174-L2905) in ConformU's default tolerant mode. Unlike the conformance
suite, INFO counts: "Received HTTP status 200 as expected but the device reported an ASCOM error"
is an INFO, and a clean protocol run has no errors, issues *or* information messages.

The values it writes back are read through ConformU's own client (``AlpacaTelescope``), as
ConformU does, and formatted with ``ToString(InvariantCulture)``.
"""

from __future__ import annotations

import json
from collections.abc import Callable
from urllib.parse import quote

import requests

from tests.conformance.ascom import (
    AlpacaTelescope,
    ConformTimeout,
    EmulatedClock,
    Stopwatch,
    dotnet_double,
    utc_date_text,
)
from tests.conformance.report import Report

TEST_CLIENT_ID = 123456
TEST_TRANSACTION_ID = 67890
BAD_PARAMETER_VALUE = "asduio6fghZZ"
NOT_IMPLEMENTED, INVALID_VALUE = 0x400, 0x401

Params = list[tuple[str, str]]

PARAMS_OK: Params = [("ClientID", str(TEST_CLIENT_ID)), ("ClientTransactionID", str(TEST_TRANSACTION_ID))]
PARAMS_OK_EXTRA: Params = [*PARAMS_OK, ("ExtraParameter", "ExtraValue")]
PARAMS_CLIENTID_LOWER: Params = [("clientid", str(TEST_CLIENT_ID)), ("ClientTransactionID", str(TEST_TRANSACTION_ID))]
PARAMS_CTID_LOWER: Params = [("ClientID", str(TEST_CLIENT_ID)), ("clienttransactionid", str(TEST_TRANSACTION_ID))]
BAD_ID_VARIANTS: tuple[tuple[str, Params], ...] = (
    ("ClientID is empty", [("ClientID", ""), ("ClientTransactionID", str(TEST_TRANSACTION_ID))]),
    ("ClientID is white space", [("ClientID", "     "), ("ClientTransactionID", str(TEST_TRANSACTION_ID))]),
    ("ClientID is negative", [("ClientID", "-12345"), ("ClientTransactionID", str(TEST_TRANSACTION_ID))]),
    ("ClientID is a string", [("ClientID", "NASDAQ"), ("ClientTransactionID", str(TEST_TRANSACTION_ID))]),
    ("ClientTransactionID is empty", [("ClientID", str(TEST_CLIENT_ID)), ("ClientTransactionID", "")]),
    ("ClientTransactionID is white space", [("ClientID", str(TEST_CLIENT_ID)), ("ClientTransactionID", "     ")]),
    ("ClientTransactionID is negative", [("ClientID", str(TEST_CLIENT_ID)), ("ClientTransactionID", "-67890")]),
    ("ClientTransactionID is a string", [("ClientID", str(TEST_CLIENT_ID)), ("ClientTransactionID", "qweqwe")]),
)
STATUS_200 = [200]
STATUS_400 = [400]
STATUS_4XX = [400, 401, 402, 403, 404, 405, 406, 407, 409, 410]
STATUS_200_OR_400 = [200, 400]  # tolerant mode for bad ID values (§C.6)
COMMON_KEYS = ("ClientTransactionID", "ServerTransactionID", "ErrorNumber", "ErrorMessage")

Wait = Callable[[], None] | None


def invert_casing(name: str) -> str:
    """APT InvertCasing: ``Axis`` -> ``aXIS``."""
    return "".join(c.lower() if c == c.upper() else c.upper() for c in name)


def parse_uint32(text: str) -> int:
    """``UInt32.TryParse`` as ConformU uses it: 0 when the text is not a plain uint32."""
    stripped = text.strip()
    if stripped.startswith("+"):
        stripped = stripped[1:]
    if stripped.isascii() and stripped.isdigit() and int(stripped) <= 0xFFFFFFFF:
        return int(stripped)
    return 0


class ProtocolTester:
    """One ``conformu alpacaprotocol`` run against ``http://host:port`` telescope 0."""

    def __init__(self, host: str, port: int, client: AlpacaTelescope, clock: EmulatedClock, report: Report,
                 *, strict: bool = False, device_number: int = 0) -> None:
        self.base = f"http://{host}:{port}"
        self.device_number = device_number
        self.t = client
        self.clock = clock
        self.report = report
        self.strict = strict
        self.session = requests.Session()
        self.session.headers.update({"Accept": "application/json", "User-Agent": "ConformUniversal/4.4.0",
                                     "Connection": "keep-alive"})
        self.requests_sent = 0

    # =================================================================================================
    # Sequence (APT TestAlpacaProtocol, TestCommon, TestTelescope)
    # =================================================================================================
    def run(self) -> None:
        r = self.report
        r.section(f"ConformU-style alpacaprotocol run against {self.base}/api/v1/telescope/{self.device_number}")
        try:
            r.section("Start-up")
            self.call_api("True", "Connected", "PUT", [*PARAMS_OK, ("Connected", "True")], STATUS_200)
            self.call_api("False", "Connected", "PUT", [*PARAMS_OK, ("Connected", "False")], STATUS_200)
            self.call_api("True (parameter order changed)", "Connected", "PUT",
                          [("ClientTransactionID", str(TEST_TRANSACTION_ID)), ("Connected", "True"),
                           ("ClientID", str(TEST_CLIENT_ID))], STATUS_200)
            self.call_api("Get interface version", "InterfaceVersion", "GET", PARAMS_OK, STATUS_200,
                          interface_version_call=True)
            r.section("Common members")
            self.test_common()
            r.section("Telescope members")
            self.test_telescope()
            r.section("Finish")
            self.call_api("False", "Connected", "PUT", [*PARAMS_OK, ("Connected", "False")], STATUS_200)
        except Exception as ex:
            r.error("", f"Protocol run stopped by an exception: {ex!r}")

    def test_common(self) -> None:
        for path, label in (
            (f"/api/v1/TELESCOPE/{self.device_number}/description", "Bad device type casing"),
            (f"/api/v1/baddevicetype/{self.device_number}/description", "Bad device type"),
            ("/api/v1/telescope/-1/description", "Bad device number (-1)"),
            ("/api/v1/telescope/99999/description", "Bad device number (99999)"),
            ("/api/v1/telescope/A/description", "Bad device number (A)"),
            (f"/api/v1/telescope/{self.device_number}/descrip", "Bad member name"),
        ):
            self.send_to_device(f"GET {path}", label, path, "GET", PARAMS_OK, STATUS_4XX, bad_uri=True)
        self.get_no_parameters("Connected")
        for bad in ("", str(TEST_CLIENT_ID), "asdqwe"):
            self.call_api(f"Bad Connected value {bad!r}", "Connected", "PUT", [*PARAMS_OK, ("Connected", bad)],
                          STATUS_400, accept_invalid_value=True)
        for member in ("Description", "DriverInfo", "DriverVersion", "InterfaceVersion", "Name", "SupportedActions"):
            self.get_no_parameters(member)
        if self.interface_version() >= 4:
            self.get_no_parameters("DeviceState")

    def interface_version(self) -> int:
        try:
            return self.t.InterfaceVersion
        except Exception:
            return 0

    def test_telescope(self) -> None:
        t = self.t
        try:
            t.Connected = True
        except Exception as ex:
            self.report.debug("Connected", f"client Connected=True failed: {ex!r}")
        if self.interface_version() >= 4:
            self.put_no_parameters("Disconnect", self.wait_not_connecting)
            self.put_no_parameters("Connect", self.wait_not_connecting)
            self.get_no_parameters("Connecting")
        for member in ("AlignmentMode", "Altitude", "ApertureArea", "ApertureDiameter", "AtHome", "AtPark", "Azimuth",
                       "CanPark", "CanPulseGuide", "CanSetDeclinationRate", "CanSetGuideRates", "CanSetPark",
                       "CanSetPierSide", "CanSetTracking", "CanSlew", "CanSlewAltAz", "CanSlewAltAzAsync", "CanSync",
                       "CanSyncAltAz", "CanUnpark", "Declination"):
            self.get_no_parameters(member)

        def value(read: Callable[[], object], fallback: str) -> str:
            try:
                v = read()
            except Exception:
                return fallback
            if isinstance(v, bool):
                return "True" if v else "False"
            if isinstance(v, float):
                return dotnet_double(v)
            return str(v)

        self.get_no_parameters("DeclinationRate")
        self.put_one_parameter("DeclinationRate", "DeclinationRate", value(lambda: t.DeclinationRate, "0.0"))
        self.get_no_parameters("DoesRefraction")
        self.put_one_parameter("DoesRefraction", "DoesRefraction", value(lambda: t.DoesRefraction, "false"))
        self.get_no_parameters("EquatorialSystem")
        self.get_no_parameters("FocalLength")
        self.get_no_parameters("GuideRateDeclination")
        self.put_one_parameter("GuideRateDeclination", "GuideRateDeclination",
                               value(lambda: t.GuideRateDeclination, "0.0"))
        self.get_no_parameters("GuideRateRightAscension")
        self.put_one_parameter("GuideRateRightAscension", "GuideRateRightAscension",
                               value(lambda: t.GuideRateRightAscension, "0.0"))
        self.get_no_parameters("IsPulseGuiding")
        self.get_no_parameters("RightAscension")
        self.get_no_parameters("RightAscensionRate")
        self.put_one_parameter("RightAscensionRate", "RightAscensionRate", value(lambda: t.RightAscensionRate, "0.0"))
        self.get_no_parameters("SideOfPier")
        self.put_one_parameter("SideOfPier", "SideOfPier", value(lambda: t.SideOfPier, "0"))
        self.get_no_parameters("SiderealTime")
        for member in ("SiteElevation", "SiteLatitude", "SiteLongitude"):
            self.get_no_parameters(member)
            self.put_one_parameter(member, member, value(lambda m=member: getattr(t, m), "0.0"))
        self.get_no_parameters("Slewing")
        self.get_no_parameters("SlewSettleTime")
        self.put_one_parameter("SlewSettleTime", "SlewSettleTime", value(lambda: t.SlewSettleTime, "0"))
        self.put_one_parameter("TargetDeclination", "TargetDeclination", value(lambda: t.TargetDeclination, "0.0"))
        self.get_no_parameters("TargetDeclination")
        self.put_one_parameter("TargetRightAscension", "TargetRightAscension",
                               value(lambda: t.TargetRightAscension, "0.0"))
        self.get_no_parameters("TargetRightAscension")
        self.get_no_parameters("Tracking")
        self.put_one_parameter("Tracking", "Tracking", value(lambda: t.Tracking, "false"))
        self.get_no_parameters("TrackingRate")
        self.put_one_parameter("TrackingRate", "TrackingRate", value(lambda: t.TrackingRate, "0"))
        self.get_no_parameters("TrackingRates")
        self.get_no_parameters("UTCDate")
        try:
            utc = utc_date_text(t.UTCDate)
        except Exception:
            utc = "2022-12-04T17:45:31.1234567Z"
        self.put_one_parameter("UTCDate", "UTCDate", utc)

        # Methods
        self.put_no_parameters("Park", None)
        self.wait_while("Park", lambda: t.Slewing)
        self.put_no_parameters("SetPark", None)
        self.put_no_parameters("Unpark", None)
        self.wait_while("Unpark", lambda: t.AtPark)
        self.put_no_parameters("FindHome", None)
        self.wait_while("FindHome", lambda: t.Slewing)
        self.call_api("True", "Tracking", "PUT", [*PARAMS_OK, ("Tracking", "True")], STATUS_200)
        self.put_no_parameters("AbortSlew", None)
        self.get_one_parameter("AxisRates", "Axis", "0")
        self.get_one_parameter("CanMoveAxis", "Axis", "0")
        ra, dec = value(lambda: t.RightAscension, "21.0"), value(lambda: t.Declination, "70")
        self.get_two_parameters("DestinationSideOfPier", "RightAscension", ra, "Declination", dec)
        self.put_two_parameters("MoveAxis", "Axis", "0", "Rate", "0.0", None)
        self.put_two_parameters("PulseGuide", "Direction", "0", "Duration", "0",
                                lambda: self.wait_while("PulseGuide", lambda: t.IsPulseGuiding, timeout_s=10))
        slewing_done = lambda: self.wait_while("Slew", lambda: t.Slewing)  # noqa: E731
        ra, dec = value(lambda: t.RightAscension, "21.0"), value(lambda: t.Declination, "70")
        self.put_two_parameters("SlewToCoordinatesAsync", "RightAscension", ra, "Declination", dec, slewing_done)
        ra, dec = value(lambda: t.RightAscension, "12.0"), value(lambda: t.Declination, "80")
        self.put_two_parameters("SlewToCoordinates", "RightAscension", ra, "Declination", dec, slewing_done)
        try:
            t.TargetRightAscension = t.RightAscension
        except Exception as ex:
            self.report.debug("TargetRightAscension", f"client write failed: {ex!r}")
        try:
            t.TargetDeclination = t.Declination
        except Exception as ex:
            self.report.debug("TargetDeclination", f"client write failed: {ex!r}")
        self.put_no_parameters("SlewToTargetAsync", slewing_done)
        self.put_no_parameters("SlewToTarget", slewing_done)
        ra, dec = value(lambda: t.RightAscension, "45"), value(lambda: t.Declination, "45")
        self.put_two_parameters("SyncToCoordinates", "RightAscension", ra, "Declination", dec, None)
        self.put_no_parameters("SyncToTarget", None)
        self.call_api("False", "Tracking", "PUT", [*PARAMS_OK, ("Tracking", "False")], STATUS_200)
        az, alt = value(lambda: t.Azimuth, "60"), value(lambda: t.Altitude, "60")
        self.put_two_parameters("SlewToAltAzAsync", "Azimuth", az, "Altitude", alt, slewing_done)
        az, alt = value(lambda: t.Azimuth, "45"), value(lambda: t.Altitude, "45")
        self.put_two_parameters("SlewToAltAz", "Azimuth", az, "Altitude", alt, slewing_done)
        az, alt = value(lambda: t.Azimuth, "45"), value(lambda: t.Altitude, "45")
        self.put_two_parameters("SyncToAltAz", "Azimuth", az, "Altitude", alt, None)
        self.call_api("False", "Tracking", "PUT", [*PARAMS_OK, ("Tracking", "False")], STATUS_200)
        try:
            t.Connected = False
        except Exception as ex:
            self.report.debug("Connected", f"client Connected=False failed: {ex!r}")

    # -- waits ------------------------------------------------------------------------------------------
    def wait_while(self, action: str, condition: Callable[[], bool], poll_ms: int = 500,
                   timeout_s: float = 300) -> None:
        """APT WaitWhile on the emulated clock; a timeout is reported as an ISSUE and the run goes on."""
        sw = Stopwatch(self.clock)
        try:
            while condition() and sw.elapsed < timeout_s:
                elapsed_ms = sw.elapsed * 1000.0
                self.clock.sleep((poll_ms * (int((elapsed_ms + 50) // poll_ms) + 1) - elapsed_ms) / 1000.0)
            if condition() and sw.elapsed >= timeout_s and condition():
                raise ConformTimeout(f'The "{action}" operation exceeded its {timeout_s:g} second timeout.')
        except Exception as ex:
            self.report.issue(action, f"Waiting for completion failed: {ex!r}")

    def wait_not_connecting(self) -> None:
        self.wait_while("Connecting", lambda: self.t.Connecting, timeout_s=5)

    # -- request patterns (APT L1473-L1856) ---------------------------------------------------------------
    def get_no_parameters(self, method: str) -> None:
        self.call_api("Good ClientID and ClientTransactionID casing", method, "GET", PARAMS_OK, STATUS_200)
        self.call_api("Good ClientID and ClientTransactionID casing with additional parameter", method, "GET",
                      PARAMS_OK_EXTRA, STATUS_200)
        self.call_api("Different ClientID casing", method, "GET", PARAMS_CLIENTID_LOWER, STATUS_200)
        self.call_api("Different ClientTransactionID casing", method, "GET", PARAMS_CTID_LOWER, STATUS_200)
        self.test_bad_id_values(method, "GET", [])

    def get_one_parameter(self, method: str, name: str, value: str) -> None:
        self.get_two_parameters(method, name, value, None, None)

    def get_two_parameters(self, method: str, name1: str, value1: str, name2: str | None, value2: str | None) -> None:
        params: Params = [(name1, value1)] + ([(name2, value2)] if name2 is not None and value2 is not None else [])
        self.call_api(f"Parameter {name1}{f' and {name2}' if name2 else ''} (Good casing)", method, "GET",
                      [*PARAMS_OK, *params], STATUS_200)
        self.call_api(f"Parameter {name1}{f' and {name2}' if name2 else ''} (Good casing with extra parameter)",
                      method, "GET", [*PARAMS_OK_EXTRA, *params], STATUS_200)
        for i, (name, _) in enumerate(params):
            bad = [(n, BAD_PARAMETER_VALUE if j == i else v) for j, (n, v) in enumerate(params)]
            self.call_api(f"Parameter {name} (Bad value)", method, "GET", [*PARAMS_OK, *bad], STATUS_400,
                          accept_invalid_value=True)
        for i, (name, _) in enumerate(params):
            inverted = [(invert_casing(n) if j == i else n, v) for j, (n, v) in enumerate(params)]
            self.call_api(f"Parameter {name} (Inverted casing)", method, "GET", [*PARAMS_OK, *inverted], STATUS_200)
        self.call_api("Different ClientID casing", method, "GET", [*PARAMS_CLIENTID_LOWER, *params], STATUS_200)
        self.call_api("Different ClientTransactionID casing", method, "GET", [*PARAMS_CTID_LOWER, *params],
                      STATUS_200)
        self.test_bad_id_values(method, "GET", params)

    def put_no_parameters(self, method: str, wait: Wait) -> None:
        self.put_parameters(method, [], wait)

    def put_one_parameter(self, method: str, name: str, value: str, wait: Wait = None) -> None:
        self.put_parameters(method, [(name, value)], wait)

    def put_two_parameters(self, method: str, name1: str, value1: str, name2: str, value2: str, wait: Wait) -> None:
        self.put_parameters(method, [(name1, value1), (name2, value2)], wait)

    def put_parameters(self, method: str, params: Params, wait: Wait) -> None:
        def done() -> None:
            if wait is not None:
                wait()

        label = " and ".join(n for n, _ in params)
        self.call_api(f"Parameters {label} (Good casing)" if params else "Good ID name casing", method, "PUT",
                      [*PARAMS_OK, *params], STATUS_200)
        done()
        self.call_api(f"Parameters {label} (Good casing + extra parameter)" if params else
                      "Good ID casing + extra parameter", method, "PUT", [*PARAMS_OK_EXTRA, *params], STATUS_200)
        done()
        for i, (name, _) in enumerate(params):
            bad = [(n, BAD_PARAMETER_VALUE if j == i else v) for j, (n, v) in enumerate(params)]
            self.call_api(f"Parameter {name} (Bad value)", method, "PUT", [*PARAMS_OK, *bad], STATUS_400,
                          accept_invalid_value=True)
        for i, (name, _) in enumerate(params):
            inverted = [(invert_casing(n) if j == i else n, v) for j, (n, v) in enumerate(params)]
            # Form names are case-sensitive: only 400 is right here (200 + 0x401 is NOT accepted).
            self.call_api(f"Parameter {name} (Bad casing)", method, "PUT", [*PARAMS_OK, *inverted], STATUS_400)
            done()
        self.call_api("Bad ClientID casing", method, "PUT", [*PARAMS_CLIENTID_LOWER, *params], STATUS_200)
        done()
        self.call_api("Bad ClientTransactionID casing", method, "PUT", [*PARAMS_CTID_LOWER, *params], STATUS_200,
                      badly_cased_ctid=True)
        done()
        self.test_bad_id_values(method, "PUT", params)
        done()

    def test_bad_id_values(self, method: str, verb: str, params: Params) -> None:
        expected = STATUS_400 if self.strict else STATUS_200_OR_400
        for label, ids in BAD_ID_VARIANTS:
            self.call_api(label, method, verb, [*ids, *params], expected, accept_invalid_value=True,
                          negative_id_test="negative" in label)

    # -- one request and its grading (APT SendToDevice, §C.2) ----------------------------------------------
    def call_api(self, prefix: str, method: str, verb: str, params: Params, expected: list[int], **flags: bool) -> None:
        path = f"/api/v1/telescope/{self.device_number}/{method.lower()}"
        self.send_to_device(f"{verb} {method}", prefix, path, verb, params, expected, **flags)

    def send_to_device(self, test: str, prefix: str, path: str, verb: str, params: Params,
                       expected: list[int], *, badly_cased_ctid: bool = False, accept_invalid_value: bool = False,
                       negative_id_test: bool = False, interface_version_call: bool = False,
                       bad_uri: bool = False) -> None:
        r = self.report
        has_ctid = False
        expected_ctid = 0
        for name, value in params:
            if name.upper() == "CLIENTTRANSACTIONID":
                has_ctid = True
                # A miscased form name must be ignored by the device: 0 is expected back.
                expected_ctid = parse_uint32(value) if verb == "GET" or name == "ClientTransactionID" else 0
        url = self.base + path
        timeout = max(self.clock.real(100.0), 5.0)
        try:
            if verb == "GET":
                query = "&".join(f"{n}={quote(v, safe='-_.~')}" for n, v in params)
                response = self.session.get(f"{url}?{query}" if query else url, timeout=timeout)
            else:
                response = self.session.request(verb, url, data=params, timeout=timeout)
            self.requests_sent += 1
        except requests.ConnectionError as ex:
            if bad_uri:
                r.ok(test, f"{prefix} - Host rejected the bad URI: {ex}")
            else:
                r.error(test, f"{prefix} - {ex}")
            return
        except requests.RequestException as ex:
            r.error(test, f"{prefix} - {ex!r}")
            return
        status = response.status_code
        text = response.text
        detail = f"{verb} {path} {params} -> {status} {text.strip()[:300]}"
        body: dict[str, object] = {}
        number, message, returned_ctid, returned_stid = 0, "", 0, 0
        if status == 200 and "<!DOCTYPE" not in text:
            if "application/imagebytes" in (response.headers.get("Content-Type") or "").lower():
                r.issue(test, f"{prefix} - a Telescope member answered with ImageBytes", detail)
                return
            try:
                parsed = json.loads(text)
                if not isinstance(parsed, dict):
                    raise ValueError("the JSON root is not an object")
                body = parsed
                returned_ctid = self._uint(body.get("ClientTransactionID", 0))
                returned_stid = self._uint(body.get("ServerTransactionID", 0))
                raw_number = body.get("ErrorNumber", 0)
                if isinstance(raw_number, bool) or not isinstance(raw_number, int):
                    raise ValueError(f"ErrorNumber {raw_number!r} is not an integer")
                number = raw_number
                raw_message = body.get("ErrorMessage", "")
                if raw_message is not None and not isinstance(raw_message, str):
                    raise ValueError(f"ErrorMessage {raw_message!r} is not a string")
                message = raw_message if raw_message is not None else ""
            except ValueError as ex:
                if not self.strict and negative_id_test:
                    r.info(test, f"{prefix} - Possibly the device returned the supplied negative ID value: {ex}",
                           detail)
                else:
                    r.error(test, f"{prefix} - Received HTTP status 200 but could not de-serialise the returned JSON "
                                  f"string: {ex}", detail)
                return
            for key in body:
                for proper in COMMON_KEYS:
                    if key.lower() == proper.lower() and key != proper:
                        r.issue(test, f"{prefix} - The {proper} JSON parameter is incorrectly cased: {key}", detail)
            if verb == "GET":
                self._check_value(test, prefix, path, body, number, detail)
        if has_ctid and status == 200:
            if returned_ctid == expected_ctid:
                r.ok(test, f"{prefix} - The expected ClientTransactionID was returned: {returned_ctid}")
            elif badly_cased_ctid and returned_ctid == TEST_TRANSACTION_ID and not self.strict:
                r.info(test, f"{prefix} - The device returned ClientTransactionID {returned_ctid} for a miscased "
                             "form parameter name: it did not treat the name as case sensitive", detail)
            else:
                r.issue(test, f"{prefix} - An unexpected ClientTransactionID was returned: {returned_ctid}, Expected: "
                              f"{expected_ctid}", detail)
        if status == 200:
            if returned_stid >= 1:
                r.ok(test, f"{prefix} - The ServerTransactionID was 1 or greater: {returned_stid}")
            elif self.strict or interface_version_call:
                r.issue(test, f"{prefix} - An unexpected ServerTransactionID was returned: {returned_stid}, "
                              "Expected: 1 or greater", detail)
            else:
                r.ok(test, f"{prefix} - ServerTransactionID 0 is tolerated in tolerant mode")
        ascom_outcome = ""
        if status == 200 and (number != 0 or message != "") and number != NOT_IMPLEMENTED:
            ascom_outcome = (f"Device returned a 0x{number:X} error for client transaction: {returned_ctid}, server "
                             f"transaction: {returned_stid}. Error message: {message}")
        if not expected:
            r.info(test, f"{prefix} - Received HTTP status {status}", detail)
        elif status in expected:
            if status == 200 and ascom_outcome:
                r.info(test, f"{prefix} - Received HTTP status 200 (OK) as expected but the device reported an ASCOM "
                             f"error: {ascom_outcome}", detail)
            else:
                r.ok(test, f"{prefix} - Received HTTP status {status} as expected.")
        elif status == 200 and accept_invalid_value and number == INVALID_VALUE:
            r.ok(test, f"{prefix} - Received HTTP status 200 (OK) and an invalid value error: {message}")
        elif status == 200 and number == NOT_IMPLEMENTED and not self.strict and expected == STATUS_400:
            r.ok(test, f"{prefix} - Received HTTP status 200 (OK) and a not implemented error (tolerant mode)")
        else:
            codes = ", ".join(str(c) for c in expected)
            r.issue(test, f"{prefix} - Expected HTTP status{'es' if len(expected) > 1 else ''}: {codes} but received "
                          f"status: {status}.", detail)

    @staticmethod
    def _uint(value: object) -> int:
        """System.Text.Json into a uint: a negative or non-integer number is a JsonException."""
        if isinstance(value, bool) or not isinstance(value, int) or not 0 <= value <= 0xFFFFFFFF:
            raise ValueError(f"{value!r} is not a uint32")
        return value

    def _check_value(self, test: str, prefix: str, path: str, body: dict[str, object], number: int,
                     detail: str) -> None:
        r = self.report
        if "Value" not in body:
            if self.strict or number == 0:
                r.issue(test, f"{prefix} - The response did not contain a Value member", detail)
            return
        value = body["Value"]
        if path.endswith("/axisrates") and isinstance(value, list):
            for item in value:
                if not isinstance(item, dict) or "Minimum" not in item or "Maximum" not in item:
                    r.issue(test, f"{prefix} - An AxisRates element lacks Minimum or Maximum (case sensitive): "
                                  f"{item!r}", detail)
        if path.endswith("/devicestate") and isinstance(value, list):
            for item in value:
                if not isinstance(item, dict) or "Name" not in item or "Value" not in item:
                    r.issue(test, f"{prefix} - A DeviceState element lacks Name or Value (case sensitive): {item!r}",
                            detail)

