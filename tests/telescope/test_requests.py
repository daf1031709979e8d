"""Malformed requests: HTTP 400 with a text body, and the member never runs; what is accepted liberally."""

from __future__ import annotations

import socket
from collections.abc import Iterator, Mapping

import pytest
import requests
from alpaca import exceptions as alpyca_exceptions
from alpaca import telescope as alpyca_telescope

from alpaca_zwo.alpaca.members import DEVICE_MEMBERS
from alpaca_zwo.server import AlpacaZwoServer
from tests.telescope.expectations import args_for
from tests.telescope.harness import Api, assert_400, wire

BAD_VALUES = {"bool": ["yes", "1", ""], "int": ["1.5", "x", "", " 1"], "float": ["abc", "1,5", "nan", "inf", ""],
              "utcdate": ["yesterday", "2030-06-01 12:00:00", "2030-13-01T00:00:00Z", ""]}


def raw(session: requests.Session, verb: str, url: str, fields: Mapping[str, str]) -> requests.Response:
    if verb == "GET":
        return session.get(url, params=fields, timeout=10)
    return session.put(url, data=fields, timeout=10)


def malformed_requests() -> Iterator[tuple[str, str, dict[str, str], str]]:
    """(verb, member, fields, why) for every parameter of every member: missing, unparseable, miscased."""
    for member in DEVICE_MEMBERS["telescope"]:
        if not member.params:
            continue
        good = {key: wire(value) for key, value in args_for(member.verb, member.name).items()}
        for param in member.params:
            if param.default is None:
                fields = {k: v for k, v in good.items() if k != param.name}
                yield member.verb, member.name, fields, f"{param.name} missing"
            for bad in BAD_VALUES.get(param.type.value, []):
                yield member.verb, member.name, {**good, param.name: bad}, f"{param.name}={bad!r}"
            if member.verb == "PUT" and param.default is None:
                fields = {k: v for k, v in good.items() if k != param.name}
                fields[param.name.lower()] = good[param.name]
                yield member.verb, member.name, fields, f"{param.name} miscased (form names are case-sensitive)"


def test_malformed_values_answer_400(api: Api) -> None:
    problems = []
    count = 0
    for verb, name, fields, why in malformed_requests():
        count += 1
        response = raw(api.session, verb, api.url(name), {"ClientID": "7", **fields})
        if response.status_code != 400 or not response.headers["Content-Type"].startswith("text/plain"):
            problems.append(f"{verb} {name} {why}: HTTP {response.status_code} {response.text[:120]!r}")
    assert count > 60
    assert not problems, "\n".join(problems)
    assert api.value("Slewing") is False and api.value("Tracking") is False  # nothing ran


@pytest.mark.parametrize("verb,name", [("GET", "RightAscension"), ("PUT", "AbortSlew"),
                                       ("GET", "DestinationSideOfPier"), ("PUT", "Tracking")])
@pytest.mark.parametrize("key,value", [("ClientID", "-1"), ("ClientID", "abc"), ("ClientID", "4294967296"),
                                       ("ClientTransactionID", "1.5"), ("ClientTransactionID", ""),
                                       ("ClientTransactionID", "-7")])
def test_bad_transaction_ids_answer_400(api: Api, verb: str, name: str, key: str, value: str) -> None:
    fields = {key: value, **{k: wire(v) for k, v in args_for(verb, name).items()}}
    if name == "Tracking":
        fields["Tracking"] = "True"
    assert_400(raw(api.session, verb, api.url(name), fields), f"{key}={value!r}")


def test_miscased_put_transaction_id_is_ignored_and_get_ids_are_case_insensitive(api: Api) -> None:
    response = api.session.put(api.url("AbortSlew"), data={"clienttransactionid": "55"}, timeout=10)
    assert response.status_code == 200 and response.json()["ClientTransactionID"] == 0
    response = api.session.get(api.url("Name"), params={"clienttransactionid": "56", "CLIENTID": "3"}, timeout=10)
    assert response.status_code == 200 and response.json()["ClientTransactionID"] == 56


@pytest.mark.parametrize("path", [
    "/api/v1/telescope/0/nosuchmember", "/api/v1/telescope/0/RightAscension", "/api/v1/Telescope/0/rightascension",
    "/api/V1/telescope/0/rightascension", "/api/v2/telescope/0/rightascension", "/api/v1/telescope/1/rightascension",
    "/api/v1/telescope/-1/rightascension", "/api/v1/telescope/x/rightascension", "/api/v1/camera/0/rightascension",
    "/api/v1/telescope/0", "/api/v1/telescope/00/rightascension",
])
def test_bad_paths_answer_400(api: Api, path: str) -> None:
    assert_400(api.session.get(api.base + path, timeout=10), path)


def test_wrong_verb_is_rejected_with_a_client_error(api: Api) -> None:
    for verb, name in [("PUT", "rightascension"), ("GET", "abortslew"), ("GET", "slewtocoordinatesasync")]:
        response = api.session.request(verb, f"{api.base}/api/v1/telescope/0/{name}", timeout=10)
        assert response.status_code in (400, 405), f"{verb} {name}: {response.status_code}"
        assert response.headers["Content-Type"].startswith("text/plain")
    for verb in ("POST", "DELETE"):
        response = api.session.request(verb, api.url("RightAscension"), timeout=10)
        assert 400 <= response.status_code < 500
    assert api.value("Slewing") is False


def test_alpyca_reports_a_bad_device_number_as_a_request_error(server: AlpacaZwoServer) -> None:
    scope = alpyca_telescope.Telescope(f"127.0.0.1:{server.port}", 7)
    with pytest.raises(alpyca_exceptions.AlpacaRequestException) as info:
        _ = scope.Name
    assert info.value.number == 400


def test_parameters_are_accepted_liberally(api: Api) -> None:
    """R2: extra parameters, ASCOM-style booleans and exponent notation are fine; GET names any case."""
    response = api.session.put(api.url("Tracking"), data={"Tracking": "tRuE", "Extra": "1", "ClientID": "9"})
    assert response.json()["ErrorNumber"] == 0 and api.value("Tracking") is True
    response = api.session.get(api.url("AxisRates"), params={"aXiS": "1", "unknown": "x"})
    assert response.json()["ErrorNumber"] == 0 and response.json()["Value"]
    api.ok("SiteElevation", SiteElevation="4.6e1")
    assert api.value("SiteElevation") == 46.0


def expect_continue_exchange(port: int, request: bytes) -> bytes:
    """Send a request carrying ``Expect: 100-continue`` on a raw socket; return everything received.

    ``requests`` never waits for the interim 100, so the raw socket shows exactly what the server sends.
    """
    with socket.create_connection(("127.0.0.1", port), timeout=5) as conn:
        head, _, body = request.partition(b"\r\n\r\n")
        conn.sendall(head + b"\r\n\r\n")
        received = b""
        if body:
            received = conn.recv(4096)  # the interim "100 Continue" comes before the body is sent
            conn.sendall(body)
        conn.settimeout(3)
        try:
            while b"\r\n\r\n{" not in received or not received.rstrip().endswith(b"}"):
                chunk = conn.recv(4096)
                if not chunk:
                    break
                received += chunk
        except TimeoutError:
            pass
    return received


def test_put_with_expect_100_continue_and_a_body(server: AlpacaZwoServer, api: Api) -> None:
    """R2: older ASCOM .NET clients send ``Expect: 100-continue`` with their form body."""
    body = b"Tracking=True&ClientID=5&ClientTransactionID=77"
    request = (b"PUT /api/v1/telescope/0/tracking HTTP/1.1\r\nHost: 127.0.0.1\r\n"
               b"Content-Type: application/x-www-form-urlencoded\r\nExpect: 100-continue\r\n"
               b"Content-Length: %d\r\n\r\n%s" % (len(body), body))
    received = expect_continue_exchange(server.port, request)
    assert b"HTTP/1.1 200 OK" in received and b'"ClientTransactionID":77' in received, received
    assert api.value("Tracking") is True


@pytest.mark.parametrize("request_bytes", [
    b"PUT /api/v1/telescope/0/abortslew HTTP/1.1\r\nHost: 127.0.0.1\r\nExpect: 100-continue\r\n"
    b"Content-Length: 0\r\n\r\n",
    b"GET /api/v1/telescope/0/name HTTP/1.1\r\nHost: 127.0.0.1\r\nExpect: 100-continue\r\n\r\n",
], ids=["put-empty-body", "get"])
def test_expect_100_continue_without_a_body_is_answered(server: AlpacaZwoServer, request_bytes: bytes) -> None:
    """A request with ``Expect: 100-continue`` but nothing to send must still get its final reply."""
    received = expect_continue_exchange(server.port, request_bytes)
    assert b"HTTP/1.1 200 OK" in received, f"only got {received!r}"
