"""The Device API over real HTTP, following ConformU's Alpaca protocol suite (checklist §C).

Each ConformU request pattern (GetNoParameters, GetOneParameter, PutNoParameters,
PutOneParameter, TestBadIdValues) is applied to every member it applies to, derived from the
member table, so a new member is covered without a new test.
"""

from __future__ import annotations

import json
import logging
import threading
from collections.abc import Iterator
from datetime import datetime, timezone
from urllib.parse import urlencode

import pytest
import requests

from alpaca_zwo._exceptions import (
    ActionNotImplemented,
    AlpacaError,
    DriverError,
    InvalidOperation,
    InvalidValue,
    MemberNotImplemented,
    NotConnected,
    Parked,
    ValueNotSet,
)
from alpaca_zwo.alpaca import create_app
from alpaca_zwo.alpaca.members import DEVICE_MEMBERS, Member, ValueType
from alpaca_zwo.clients import ClientKey, ClientRegistry
from tests.alpaca.conftest import BAD_VALUE, CLIENT_ID, CTID, OK_IDS, Alpaca, StandInTelescope

MEMBERS = DEVICE_MEMBERS["telescope"]
GET_PLAIN = [m for m in MEMBERS if m.verb == "GET" and not m.params]
GET_PARAMS = [m for m in MEMBERS if m.verb == "GET" and m.params]
PUT_PLAIN = [m for m in MEMBERS if m.verb == "PUT" and not m.params]
PUT_PARAMS = [m for m in MEMBERS if m.verb == "PUT" and m.params]
ENVELOPE = {"ClientTransactionID", "ServerTransactionID", "ErrorNumber", "ErrorMessage"}
CONFORMU_4XX = {400, 401, 402, 403, 404, 405, 406, 407, 409, 410}

VALID = {ValueType.BOOL: "False", ValueType.INT: "0", ValueType.FLOAT: "0.0", ValueType.STR: "echo",
         ValueType.UTCDATE: "2022-12-04T17:45:31.1234567Z"}
BAD_VALUES = {
    ValueType.BOOL: [BAD_VALUE, "", "1", "yes"],
    ValueType.INT: [BAD_VALUE, "", "nan", "1.5", "1,5", " 1", "1_000"],
    ValueType.FLOAT: [BAD_VALUE, "", "nan", "inf", "-inf", "1,5", "23,456", " 1", "1_000"],
    ValueType.UTCDATE: [BAD_VALUE, "", "2022-12-04T17:45:31", "2022-12-04T17:45:31.Z"],
}
BAD_IDS = [("ClientID", ""), ("ClientID", "     "), ("ClientID", "-12345"), ("ClientID", "NASDAQ"),
           ("ClientTransactionID", ""), ("ClientTransactionID", "     "), ("ClientTransactionID", "-67890"),
           ("ClientTransactionID", "qweqwe")]


def member(verb: str, path: str) -> Member:
    return next(m for m in MEMBERS if m.verb == verb and m.path == path)


def ident(m: Member) -> str:
    return f"{m.verb}-{m.path}"


def valid(m: Member) -> dict[str, str]:
    return {p.name: VALID[p.type] for p in m.params}


def send(alpaca: Alpaca, m: Member, fields: dict[str, str], **kw: object) -> requests.Response:
    """Send fields exactly as named (no re-casing), in the query for GET and the form body for PUT."""
    encoded = urlencode(fields)
    if m.verb == "GET":
        return alpaca.http_get_query(m.path, encoded, **kw)
    return alpaca.http_put_body(m.path, encoded, **kw)


def assert_json(r: requests.Response, m: Member | None = None, *, ctid: int | None = None,
                error: int = 0) -> dict:
    """200, application/json, exactly the right keys with exact casing, and the expected outcome."""
    assert r.status_code == 200, r.text
    assert r.headers["Content-Type"] == "application/json"
    body = r.json()
    if m is None:  # shape of the member not asserted here: envelope plus at most Value
        assert ENVELOPE <= set(body) <= ENVELOPE | {"Value"}
    else:
        assert set(body) == ENVELOPE | ({"Value"} if m.returns else set())
    if ctid is not None:
        assert body["ClientTransactionID"] == ctid
    assert body["ServerTransactionID"] >= 1
    assert body["ErrorNumber"] == error
    if error:
        assert body["ErrorMessage"]
        if m is not None and m.returns:  # the type's default, never null (protocol-rules §6)
            assert body["Value"] == json.loads(json.dumps(m.error_value))
        if "Value" in body:
            assert body["Value"] is not None
    else:
        assert body["ErrorMessage"] == ""
    return body


def assert_text(r: requests.Response, status: int = 400) -> str:
    assert r.status_code == status, r.text
    assert r.headers["Content-Type"].startswith("text/plain")
    assert r.text.strip()
    return r.text


def invert_case(name: str) -> str:
    return name.swapcase()


# --- URLs ----------------------------------------------------------------------------------------

BAD_PATHS = [
    "/api/v1/TELESCOPE/0/description",  # ConformU §C.4
    "/api/v1/baddevicetype/0/description",
    "/api/v1/telescope/-1/description",
    "/api/v1/telescope/99999/description",
    "/api/v1/telescope/A/description",
    "/api/v1/telescope/0/descrip",
    "/API/V1/TELESCOPE/0/CANSLEW",  # protocol-rules §1 / §5
    "/api/v1/telescopE/0/canslew",
    "/api/v1/telescope/0/CanSlew",
    "/apii/v1/telescope/0/canslew",
    "/api/v2/telescope/0/canslew",
    "/api/1/telescope/0/description",
    "/api/v/telescope/0/description",
    "/api/V1/telescope/0/description",
    "/api/v1/telescop/0/canslew",
    "/api/v1/camera/0/canslew",
    "/api/v1/telescope/1/canslew",
    "/api/v1/telescope/00/canslew",
    "/api/v1/telescope/4294967296/canslew",
    "/api/v1/telescope//canslew",
    "/api/v1/telescope/0/canslew/",
    "/api/v1/telescope/0/canslew/extra",
    "/api/v1/telescope/0",
    "/api",
]


@pytest.mark.parametrize("path", BAD_PATHS)
def test_bad_paths_are_400_text(alpaca: Alpaca, path: str) -> None:
    r = alpaca.session.get(f"{alpaca.base}{path}", params=OK_IDS, timeout=10)
    assert_text(r, 400)


@pytest.mark.parametrize("path", BAD_PATHS[:6])
def test_bad_paths_put_are_400(alpaca: Alpaca, path: str) -> None:
    r = alpaca.session.put(f"{alpaca.base}{path}", data={**OK_IDS, "Connected": "True"}, timeout=10)
    assert_text(r, 400)
    assert not alpaca.device.calls


def test_unknown_top_level_path_is_a_conformu_4xx(alpaca: Alpaca) -> None:
    r = alpaca.session.get(f"{alpaca.base}/apx/v1/telescope/0/description", timeout=10)
    assert r.status_code in CONFORMU_4XX
    assert r.headers["Content-Type"].startswith("text/plain")


@pytest.mark.parametrize("verb", ["POST", "DELETE", "PATCH"])
def test_other_verbs_rejected(alpaca: Alpaca, verb: str) -> None:
    for value in ("True", "", "123456"):
        r = alpaca.session.request(verb, alpaca.url("connected"), data={**OK_IDS, "Connected": value}, timeout=10)
        assert r.status_code in (400, 405)
        assert r.headers["Content-Type"].startswith("text/plain")
    assert not alpaca.device.called("set_connected")


@pytest.mark.parametrize("verb", ["POST", "DELETE"])
def test_post_delete_are_405_with_allow(alpaca: Alpaca, verb: str) -> None:
    r = alpaca.session.request(verb, alpaca.url("connected"), data={**OK_IDS, "Connected": "True"}, timeout=10)
    assert_text(r, 405)
    assert "GET" in r.headers["Allow"] and "PUT" in r.headers["Allow"]


def test_wrong_verb_for_member_is_405(alpaca: Alpaca) -> None:
    r = alpaca.http_get("abortslew", OK_IDS)
    assert_text(r, 405)
    assert r.headers["Allow"] == "PUT"
    r = alpaca.http_put("canslew", OK_IDS)
    assert_text(r, 405)
    assert r.headers["Allow"] == "GET"
    assert not alpaca.device.calls


# --- GetNoParameters / PutNoParameters -------------------------------------------------------------


@pytest.mark.parametrize("m", GET_PLAIN, ids=ident)
def test_get_no_parameters(alpaca: Alpaca, m: Member) -> None:
    error = 0x402 if m.path in ("targetdeclination", "targetrightascension") else 0
    assert_json(send(alpaca, m, OK_IDS), m, ctid=CTID, error=error)
    assert_json(send(alpaca, m, {**OK_IDS, "ExtraParameter": "ExtraValue"}), m, ctid=CTID, error=error)
    assert_json(send(alpaca, m, {"clientid": str(CLIENT_ID), "ClientTransactionID": str(CTID)}), m,
                ctid=CTID, error=error)
    # Query names are case-insensitive, so a lower-case clienttransactionid must round-trip.
    assert_json(send(alpaca, m, {"ClientID": str(CLIENT_ID), "clienttransactionid": str(CTID)}), m,
                ctid=CTID, error=error)
    if m.constant is not None:  # answered by the member table itself: the device is never asked
        assert not alpaca.device.calls
        assert send(alpaca, m, OK_IDS).json()["Value"] == m.constant.value
        return
    assert all(c.client == ClientKey("127.0.0.1", CLIENT_ID) for c in alpaca.device.called(m.handler))
    assert len(alpaca.device.called(m.handler)) == 4


@pytest.mark.parametrize("m", PUT_PLAIN, ids=ident)
def test_put_no_parameters(alpaca: Alpaca, m: Member) -> None:
    device = alpaca.device
    device.set_target_right_ascension(1.0)  # so SlewToTarget/SyncToTarget succeed
    device.set_target_declination(2.0)
    assert_json(send(alpaca, m, OK_IDS), m, ctid=CTID)
    assert_json(send(alpaca, m, {**OK_IDS, "ExtraParameter": "ExtraValue"}), m, ctid=CTID)
    # Form names are case-sensitive: a miscased key is ignored, i.e. treated as absent.
    assert_json(send(alpaca, m, {"clientid": str(CLIENT_ID), "ClientTransactionID": str(CTID)}), m, ctid=CTID)
    assert device.called(m.handler)[-1].client == ClientKey("127.0.0.1", 0)
    assert_json(send(alpaca, m, {"ClientID": str(CLIENT_ID), "clienttransactionid": str(CTID)}), m, ctid=0)
    assert device.called(m.handler)[-1].client == ClientKey("127.0.0.1", CLIENT_ID)
    assert len(device.called(m.handler)) == 4


# --- GetOneParameter / GetTwoParameters ---------------------------------------------------------------


@pytest.mark.parametrize("m", GET_PARAMS, ids=ident)
def test_get_with_parameters(alpaca: Alpaca, m: Member) -> None:
    device = alpaca.device
    values = {p.name: "1" for p in m.params}
    expected = {p.kwarg: (1 if p.type is ValueType.INT else 1.0) for p in m.params}
    assert_json(send(alpaca, m, {**OK_IDS, **values}), m, ctid=CTID)
    assert device.calls[-1].kwargs == expected
    assert_json(send(alpaca, m, {**OK_IDS, **values, "ExtraParameter": "ExtraValue"}), m, ctid=CTID)
    # Case-inverted names (aXIS=1) are the same parameter on GET, and the value is used.
    inverted = {invert_case(k): v for k, v in values.items()}
    assert_json(send(alpaca, m, {**OK_IDS, **inverted}), m, ctid=CTID)
    assert device.calls[-1].kwargs == expected
    assert_json(send(alpaca, m, {"clientid": str(CLIENT_ID), "ClientTransactionID": str(CTID), **values}), m,
                ctid=CTID)
    assert_json(send(alpaca, m, {"ClientID": str(CLIENT_ID), "clienttransactionid": str(CTID), **values}), m,
                ctid=CTID)
    assert len(device.called(m.handler)) == 5


@pytest.mark.parametrize(("m", "name", "bad"), [
    (m, p.name, bad) for m in GET_PARAMS for p in m.params for bad in BAD_VALUES[p.type]
], ids=str)
def test_get_bad_parameter_value(alpaca: Alpaca, m: Member, name: str, bad: str) -> None:
    fields = {**OK_IDS, **{p.name: "0" for p in m.params}, name: bad}
    text = assert_text(send(alpaca, m, fields))
    assert name in text
    assert not alpaca.device.calls


@pytest.mark.parametrize("m", GET_PARAMS, ids=ident)
def test_get_missing_parameter(alpaca: Alpaca, m: Member) -> None:
    assert "Missing parameter" in assert_text(send(alpaca, m, OK_IDS))
    assert not alpaca.device.calls


# --- PutOneParameter / PutTwoParameters ---------------------------------------------------------------


@pytest.mark.parametrize("m", PUT_PARAMS, ids=ident)
def test_put_with_parameters(alpaca: Alpaca, m: Member) -> None:
    device = alpaca.device
    values = valid(m)
    r = send(alpaca, m, {**OK_IDS, **values})
    assert r.status_code == 200
    assert set(r.json()) == ENVELOPE | ({"Value"} if m.returns else set())
    assert r.json()["ClientTransactionID"] == CTID
    assert send(alpaca, m, {**OK_IDS, **values, "ExtraParameter": "ExtraValue"}).status_code == 200
    called = len(device.called(m.handler))
    assert called == 2
    # A case-inverted form name is a missing parameter: 400, and the member must not run.
    for name in (p.name for p in m.params if p.default is None):
        fields = {**OK_IDS, **values}
        fields[invert_case(name)] = fields.pop(name)
        assert "case-sensitive" in assert_text(send(alpaca, m, fields))
    assert len(device.called(m.handler)) == called
    r = send(alpaca, m, {"clientid": str(CLIENT_ID), "ClientTransactionID": str(CTID), **values})
    assert r.status_code == 200 and r.json()["ClientTransactionID"] == CTID
    r = send(alpaca, m, {"ClientID": str(CLIENT_ID), "clienttransactionid": str(CTID), **values})
    assert r.status_code == 200 and r.json()["ClientTransactionID"] == 0


@pytest.mark.parametrize(("m", "name", "bad"), [
    (m, p.name, bad) for m in PUT_PARAMS for p in m.params if p.type in BAD_VALUES for bad in BAD_VALUES[p.type]
], ids=str)
def test_put_bad_parameter_value(alpaca: Alpaca, m: Member, name: str, bad: str) -> None:
    fields = {**OK_IDS, **valid(m), name: bad}
    text = assert_text(send(alpaca, m, fields))
    assert name in text
    assert not alpaca.device.calls


@pytest.mark.parametrize("m", PUT_PARAMS, ids=ident)
def test_put_missing_parameter(alpaca: Alpaca, m: Member) -> None:
    assert "Missing parameter" in assert_text(send(alpaca, m, OK_IDS))
    assert not alpaca.device.calls


def test_string_parameters_may_be_empty(alpaca: Alpaca) -> None:
    body = assert_json(alpaca.http_put("action", {**OK_IDS, "Action": "echo", "Parameters": ""}), ctid=CTID)
    assert body["Value"] == ""


def test_action_parameters_default_to_empty(alpaca: Alpaca) -> None:
    # alpyca's Action(name) sends no Parameters field at all.
    assert assert_json(alpaca.http_put("action", {**OK_IDS, "Action": "echo"}), ctid=CTID)["Value"] == ""
    assert alpaca.device.calls[-1].kwargs == {"action": "echo", "parameters": ""}
    assert_text(alpaca.http_put("action", {**OK_IDS, "Parameters": "x"}))


def test_put_arguments_reach_the_handler_typed(alpaca: Alpaca) -> None:
    device = alpaca.device
    alpaca.http_put("tracking", {"Tracking": "TRUE"})
    assert device.calls[-1].args == (True,) and device.calls[-1].kwargs == {}
    alpaca.http_put("moveaxis", {"Axis": "1", "Rate": "-1.5"})
    assert device.calls[-1].kwargs == {"axis": 1, "rate": -1.5}
    alpaca.http_put("pulseguide", {"Direction": "3", "Duration": "0"})
    assert device.calls[-1].kwargs == {"direction": 3, "duration": 0}
    alpaca.http_put("slewtocoordinatesasync", {"RightAscension": "23.9999999999", "Declination": "-90"})
    assert device.calls[-1].kwargs == {"right_ascension": 23.9999999999, "declination": -90.0}
    alpaca.http_put("commandblind", {"Command": ":GR#", "Raw": "true"})
    assert device.calls[-1].kwargs == {"command": ":GR#", "raw": True}
    alpaca.http_put("utcdate", {"UTCDate": "2016-03-04T17:45:31.1234567Z"})
    assert device.calls[-1].args == (datetime(2016, 3, 4, 17, 45, 31, 123456, tzinfo=timezone.utc),)


def test_put_reads_only_the_body(alpaca: Alpaca) -> None:
    r = alpaca.session.put(alpaca.url("tracking") + "?Tracking=True&ClientTransactionID=5", timeout=10)
    assert_text(r)
    assert not alpaca.device.calls


def test_put_body_not_utf8_is_400(alpaca: Alpaca) -> None:
    assert_text(alpaca.http_put_body("tracking", b"Tracking=True&Extra=\xff\xfe"))


# --- TestBadIdValues -------------------------------------------------------------------------------


BAD_ID_TARGETS = [m for m in MEMBERS if (m.verb, m.path) in {("GET", "canslew"), ("GET", "axisrates"),
                                                             ("PUT", "abortslew"), ("PUT", "tracking"),
                                                             ("GET", "devicestate"), ("PUT", "connected")}]


@pytest.mark.parametrize("m", BAD_ID_TARGETS, ids=ident)
@pytest.mark.parametrize(("key", "bad"), BAD_IDS)
def test_bad_id_values_are_400(alpaca: Alpaca, m: Member, key: str, bad: str) -> None:
    fields = {**OK_IDS, **valid(m), key: bad}
    assert key in assert_text(send(alpaca, m, fields))
    assert not alpaca.device.calls


@pytest.mark.parametrize("key", ["ClientID", "ClientTransactionID"])
def test_id_out_of_uint32_range_is_400(alpaca: Alpaca, key: str) -> None:
    assert_text(alpaca.http_get("canslew", {**OK_IDS, key: "4294967296"}))
    assert_json(alpaca.http_get("canslew", {**OK_IDS, key: "4294967295"}))


def test_absent_ids_echo_zero(alpaca: Alpaca) -> None:
    assert_json(alpaca.http_get("cansetpierside"), ctid=0)
    assert alpaca.device.calls[-1].client == ClientKey("127.0.0.1", 0)
    assert_json(alpaca.http_put("abortslew"), member("PUT", "abortslew"), ctid=0)


# --- transaction IDs ---------------------------------------------------------------------------------


def test_ctid_echo_and_stid_from_one(alpaca: Alpaca) -> None:
    stids = []
    for ctid in range(1, 21):
        member = "canslew" if ctid % 2 else "tracking"
        r = alpaca.http_get(member, {"ClientID": "1", "ClientTransactionID": str(ctid * 7)})
        body = assert_json(r, ctid=ctid * 7)
        stids.append(body["ServerTransactionID"])
    assert stids == list(range(1, 21))


def test_stid_counts_errors_and_puts(alpaca: Alpaca) -> None:
    assert alpaca.http_get("targetdeclination").json()["ServerTransactionID"] == 1
    assert alpaca.http_put("park").json()["ServerTransactionID"] == 2
    assert alpaca.http_get("canslew").json()["ServerTransactionID"] == 3


def test_stid_unique_and_monotonic_across_threads(make_alpaca) -> None:
    alpaca = make_alpaca(threads=16)
    per_thread = 40
    results: dict[int, list[tuple[int, int]]] = {}
    errors: list[BaseException] = []

    def hammer(worker: int) -> None:
        try:
            with requests.Session() as session:
                mine = []
                for i in range(per_thread):
                    ctid = worker * 1000 + i
                    verb = "put" if i % 5 == 0 else "get"
                    if verb == "get":
                        r = session.get(alpaca.url("rightascension"),
                                        params={"ClientID": str(worker), "ClientTransactionID": str(ctid)},
                                        timeout=10)
                    else:
                        r = session.put(alpaca.url("tracking"), data={"Tracking": "True", "ClientID": str(worker),
                                                                      "ClientTransactionID": str(ctid)}, timeout=10)
                    body = r.json()
                    mine.append((body["ClientTransactionID"], body["ServerTransactionID"]))
                    assert body["ClientTransactionID"] == ctid
                results[worker] = mine
        except BaseException as exc:
            errors.append(exc)

    workers = [threading.Thread(target=hammer, args=(w,)) for w in range(24)]
    for t in workers:
        t.start()
    for t in workers:
        t.join()
    assert not errors
    stids = [stid for mine in results.values() for _, stid in mine]
    assert len(stids) == 24 * per_thread
    assert sorted(stids) == list(range(1, len(stids) + 1))  # unique, gap-free, from 1
    for mine in results.values():
        own = [stid for _, stid in mine]
        assert own == sorted(own)
    clients = {a.key.client_id for a in alpaca.registry.snapshot()}
    assert clients == set(range(24))


# --- JSON shape, values and ASCOM errors ---------------------------------------------------------------


def test_exact_json_bytes(alpaca: Alpaca) -> None:
    r = alpaca.http_get("canslew", {"ClientID": "1", "ClientTransactionID": "20"})
    assert r.content == b'{"Value":true,"ClientTransactionID":20,"ServerTransactionID":1,"ErrorNumber":0,' \
                        b'"ErrorMessage":""}'
    r = alpaca.http_put("siteelevation", {"SiteElevation": "-400", "ClientID": "1", "ClientTransactionID": "23"})
    assert json.loads(r.content) == {"ClientTransactionID": 23, "ServerTransactionID": 2, "ErrorNumber": 0x401,
                                     "ErrorMessage": "SiteElevation -400.0 is outside -300..10000"}


def test_structured_values(alpaca: Alpaca) -> None:
    assert alpaca.http_get("utcdate").json()["Value"] == "2024-01-31T21:05:00.1234560Z"
    assert alpaca.http_get("axisrates", {"Axis": "0"}).json()["Value"] == [{"Minimum": 0.0, "Maximum": 4.0}]
    assert alpaca.http_get("axisrates", {"Axis": "2"}).json()["Value"] == []
    assert alpaca.http_get("trackingrates").json()["Value"] == [0, 1, 2]
    assert alpaca.http_get("supportedactions").json()["Value"] == ["echo"]
    state = alpaca.http_get("devicestate").json()["Value"]
    assert all(set(item) == {"Name", "Value"} for item in state)
    as_dict = {item["Name"]: item["Value"] for item in state}
    assert as_dict["UTCDate"] == "2024-01-31T21:05:00.1234560Z"
    assert as_dict["Tracking"] is False
    assert alpaca.http_get("interfaceversion").json()["Value"] == 4


def test_utc_date_round_trip(alpaca: Alpaca) -> None:
    assert_json(alpaca.http_put("utcdate", {"UTCDate": "2022-12-04T17:45:31.1234567Z"}))
    assert alpaca.http_get("utcdate").json()["Value"] == "2022-12-04T17:45:31.1234560Z"


def test_value_is_the_type_default_on_error(alpaca: Alpaca) -> None:
    body = assert_json(alpaca.http_get("targetdeclination", OK_IDS), ctid=CTID, error=0x402)
    assert body["Value"] == 0.0 and isinstance(body["Value"], float) and "not been set" in body["ErrorMessage"]


def test_put_error_has_no_value(alpaca: Alpaca) -> None:
    alpaca.http_put("park")
    body = assert_json(alpaca.http_put("tracking", {**OK_IDS, "Tracking": "True"}), member("PUT", "tracking"),
                       ctid=CTID, error=0x408)
    assert "Value" not in body


def test_value_returning_put_error_has_default_value(alpaca: Alpaca) -> None:
    body = alpaca.http_put("action", {"Action": "nope", "Parameters": ""}).json()
    assert body["ErrorNumber"] == 0x40C and body["Value"] == ""
    assert alpaca.http_put("action", {"Action": "echo", "Parameters": "hi"}).json()["Value"] == "hi"


@pytest.mark.parametrize("error", [MemberNotImplemented, InvalidValue, ValueNotSet, NotConnected, Parked,
                                   InvalidOperation, ActionNotImplemented, DriverError])
@pytest.mark.parametrize("member", ["slewing", "abortslew"])
def test_alpaca_errors_are_200_with_number(alpaca: Alpaca, error: type[AlpacaError], member: str) -> None:
    m = next(m for m in MEMBERS if m.path == member)
    alpaca.device.faults[m.handler] = error(f"{error.__name__} from the device")
    body = assert_json(send(alpaca, m, OK_IDS), m, ctid=CTID, error=error.number)
    assert body["ErrorMessage"] == f"{error.__name__} from the device"


def test_driver_error_keeps_its_own_number(alpaca: Alpaca) -> None:
    alpaca.device.faults["slewing"] = DriverError("link lost", 0x520)
    assert_json(alpaca.http_get("slewing"), error=0x520)


def test_error_number_zero_is_never_sent_as_success(alpaca: Alpaca) -> None:
    alpaca.device.faults["slewing"] = AlpacaError("", 0)
    body = assert_json(alpaca.http_get("slewing"), error=0x500)
    assert body["ErrorMessage"] == "AlpacaError"


def test_exploding_handler_is_500_and_server_keeps_serving(alpaca: Alpaca,
                                                            caplog: pytest.LogCaptureFixture) -> None:
    alpaca.device.faults["slewing"] = RuntimeError("boom")
    with caplog.at_level(logging.ERROR, logger="alpaca_zwo.alpaca"):
        r = alpaca.http_get("slewing", OK_IDS)
    body = assert_text(r, 500)
    assert "RuntimeError" in body and "boom" not in body  # the type only: the text may hold internals
    assert any(rec.exc_info and "boom" in str(rec.exc_info[1]) for rec in caplog.records)
    assert_json(alpaca.http_get("canslew", OK_IDS), ctid=CTID)
    r = alpaca.http_put("abortslew", OK_IDS)
    assert_json(r, member("PUT", "abortslew"), ctid=CTID)
    del alpaca.device.faults["slewing"]
    assert alpaca.http_get("slewing").json()["Value"] is False


@pytest.mark.parametrize(("member", "value"), [("rightascension", float("nan")), ("declination", float("inf")),
                                               ("utcdate", datetime(2024, 1, 1))])
def test_unencodable_values_are_500(alpaca: Alpaca, member: str, value: object) -> None:
    handler = next(m.handler for m in MEMBERS if m.path == member)
    alpaca.device.faults[handler] = lambda: value
    assert_text(alpaca.http_get(member), 500)
    assert_json(alpaca.http_get("canslew"))


def test_handler_sees_current_client_and_registry_records_it(alpaca: Alpaca) -> None:
    alpaca.http_get("cansetpierside", OK_IDS, headers={"User-Agent": "ConformUniversal/4.4.0"})
    assert alpaca.device.calls[-1].client == ClientKey("127.0.0.1", CLIENT_ID)
    [activity] = alpaca.registry.snapshot()
    assert activity.key == ClientKey("127.0.0.1", CLIENT_ID)
    assert activity.user_agent == "ConformUniversal/4.4.0"
    assert activity.requests == 1


def test_forwarded_headers_do_not_spoof_the_client(alpaca: Alpaca) -> None:
    alpaca.http_get("cansetpierside", OK_IDS, headers={"X-Forwarded-For": "10.9.8.7", "Forwarded": "for=10.9.8.7"})
    assert alpaca.device.calls[-1].client == ClientKey("127.0.0.1", CLIENT_ID)


def test_conformu_startup_sequence(alpaca: Alpaca) -> None:
    device = alpaca.device
    assert_json(alpaca.http_put_body("connected", "ClientID=123456&ClientTransactionID=67890&Connected=True"),
                ctid=CTID, m=member("PUT", "connected"))
    assert device.connected() is True
    assert_json(alpaca.http_put_body("connected", "ClientID=123456&ClientTransactionID=67890&Connected=False"),
                ctid=CTID, m=member("PUT", "connected"))
    assert device.connected() is False
    assert_json(alpaca.http_put_body("connected", "ClientTransactionID=67890&Connected=True&ClientID=123456"),
                ctid=CTID, m=member("PUT", "connected"))
    assert device.connected() is True
    body = assert_json(alpaca.http_get("interfaceversion", OK_IDS), ctid=CTID)
    assert body["Value"] == 4 and body["ServerTransactionID"] == 4


@pytest.mark.parametrize("bad", ["", "123456", "asdqwe"])
def test_bad_connected_values_are_400(alpaca: Alpaca, bad: str) -> None:
    assert_text(alpaca.http_put("connected", {**OK_IDS, "Connected": bad}))
    assert not alpaca.device.calls


# --- body limit, auth, logging, composition -----------------------------------------------------------


def test_oversize_body_is_413(make_alpaca) -> None:
    alpaca = make_alpaca(max_body_bytes=100)
    body = "Tracking=True&ClientTransactionID=1&Pad="
    assert_json(alpaca.http_put_body("tracking", body + "x" * (100 - len(body))))
    assert_text(alpaca.http_put_body("tracking", body + "x" * (101 - len(body))), 413)
    assert len(alpaca.device.called("set_tracking")) == 1


def test_oversize_chunked_body_is_413(make_alpaca) -> None:
    alpaca = make_alpaca(max_body_bytes=100)

    def chunks() -> Iterator[bytes]:
        yield b"Tracking=True&Pad="
        for _ in range(10):
            yield b"x" * 20

    assert_text(alpaca.http_put_body("tracking", chunks()), 413)  # type: ignore[arg-type]
    assert not alpaca.device.calls
    assert_json(alpaca.http_put_body("tracking", iter([b"Tracking=", b"True"])))  # type: ignore[arg-type]


def test_default_limit_accepts_normal_bodies(alpaca: Alpaca) -> None:
    assert_json(alpaca.http_put("action", {"Action": "echo", "Parameters": "p" * 60000}))
    assert_text(alpaca.http_put("action", {"Action": "echo", "Parameters": "p" * 70000}), 413)


class _SetupPage:
    def on_get(self, req, resp) -> None:
        resp.content_type = "text/html"
        resp.text = "<h1>setup</h1>"


def test_basic_auth(make_alpaca) -> None:
    alpaca = make_alpaca(basic_auth=("astro", "pa:ss wörd"), extra_routes=[("/setup", _SetupPage())])
    for path in ("/api/v1/telescope/0/canslew", "/management/apiversions", "/setup", "/api/v1/nope/0/x"):
        r = alpaca.session.get(alpaca.base + path, timeout=10)
        assert_text(r, 401)
        assert r.headers["WWW-Authenticate"].startswith("Basic realm=")
    for auth in [("astro", "wrong"), ("other", "pa:ss wörd"), ("astro", "pa:ss"), ("", "")]:
        assert_text(alpaca.http_get("canslew", auth=auth), 401)
    for header in ["Bearer abc", "Basic !!!notbase64", "Basic", "Basic YXN0cm8="]:
        assert_text(alpaca.http_get("canslew", headers={"Authorization": header}), 401)
    assert_text(alpaca.http_put("tracking", {"Tracking": "True"}), 401)
    assert not alpaca.device.calls
    good = requests.auth.HTTPBasicAuth("astro", "pa:ss wörd".encode())
    assert_json(alpaca.http_get("canslew", auth=good))
    assert_json(alpaca.http_put("tracking", {"Tracking": "True"}, auth=good))
    assert alpaca.session.get(alpaca.base + "/setup", auth=good, timeout=10).text == "<h1>setup</h1>"
    assert alpaca.session.get(alpaca.base + "/management/apiversions", auth=good, timeout=10).json()["Value"] == [1]


def test_no_auth_by_default(alpaca: Alpaca) -> None:
    r = alpaca.http_get("canslew", headers={"Authorization": "Basic Zm9vOmJhcg=="})
    assert_json(r)
    assert "WWW-Authenticate" not in r.headers


def test_extra_routes_mounted(make_alpaca) -> None:
    alpaca = make_alpaca(extra_routes=[("/setup", _SetupPage())])
    r = alpaca.session.get(alpaca.base + "/setup", timeout=10)
    assert r.status_code == 200 and r.text == "<h1>setup</h1>"
    assert_text(alpaca.session.get(alpaca.base + "/setup/v1/telescope/0/setup", timeout=10), 404)


def test_logging(alpaca: Alpaca, caplog: pytest.LogCaptureFixture) -> None:
    with caplog.at_level(logging.DEBUG, logger="alpaca_zwo.alpaca"):
        alpaca.http_get("canslew", OK_IDS)
        alpaca.http_put("tracking", {**OK_IDS, "Tracking": "True"})
        alpaca.http_get("nope", OK_IDS)
    access = [r.getMessage() for r in caplog.records if r.name == "alpaca_zwo.alpaca.access"]
    assert len(access) == 3
    assert "GET /api/v1/telescope/0/canslew" in access[0] and "ctid=67890" in access[0]
    assert "127.0.0.1#123456" in access[0] and "-> 200" in access[0] and "ms" in access[0]
    assert "-> 400" in access[2]
    info = [r.getMessage() for r in caplog.records if r.levelno == logging.INFO]
    assert info == ["Tracking(Tracking=True) by 127.0.0.1#123456: ok"]


def test_put_errors_are_logged_at_info(alpaca: Alpaca, caplog: pytest.LogCaptureFixture) -> None:
    with caplog.at_level(logging.INFO, logger="alpaca_zwo.alpaca"):
        alpaca.http_put("siteelevation", {**OK_IDS, "SiteElevation": "-400"})
    assert [r.getMessage() for r in caplog.records] == [
        "SiteElevation(SiteElevation=-400.0) by 127.0.0.1#123456: error 0x401 "
        "SiteElevation -400.0 is outside -300..10000"]


def test_access_log_suppressible(alpaca: Alpaca, caplog: pytest.LogCaptureFixture) -> None:
    with caplog.at_level(logging.INFO, logger="alpaca_zwo.alpaca"):
        alpaca.http_get("canslew", OK_IDS)
    assert not [r for r in caplog.records if r.name == "alpaca_zwo.alpaca.access"]


def test_two_devices(make_alpaca) -> None:
    first, second = StandInTelescope("first", "uid-1"), StandInTelescope("second", "uid-2")
    alpaca = make_alpaca([first, second])
    assert alpaca.session.get(alpaca.url("name", 1), timeout=10).json()["Value"] == "second"
    assert alpaca.session.get(alpaca.url("name", 0), timeout=10).json()["Value"] == "first"
    assert_text(alpaca.session.get(alpaca.url("name", 2), timeout=10))


def test_incomplete_device_is_rejected_at_startup() -> None:
    class Half:
        device_name = "half"
        unique_id = "x"

        def tracking(self) -> bool:
            return True

    with pytest.raises(TypeError, match="set_tracking"):
        create_app([Half()], ClientRegistry(), None)  # type: ignore[list-item, arg-type]


def test_options_and_head(alpaca: Alpaca) -> None:
    r = alpaca.session.options(alpaca.url("canslew"), timeout=10)
    assert r.status_code == 200 and "GET" in r.headers["Allow"]
    assert alpaca.session.head(alpaca.url("canslew"), timeout=10).status_code == 405
