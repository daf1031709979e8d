"""The Alpaca Management API over real HTTP."""

from __future__ import annotations

import pytest

from alpaca_zwo.clients import ClientKey
from tests.alpaca.conftest import CTID, OK_IDS, SERVER_INFO, Alpaca, StandInTelescope

KEYS = {"Value", "ClientTransactionID", "ServerTransactionID", "ErrorNumber", "ErrorMessage"}


def get(alpaca: Alpaca, path: str, params: dict[str, str] | None = None, **kw: object):
    return alpaca.session.get(alpaca.base + path, params=params, timeout=10, **kw)


def test_apiversions(alpaca: Alpaca) -> None:
    r = get(alpaca, "/management/apiversions", OK_IDS)
    assert r.status_code == 200 and r.headers["Content-Type"] == "application/json"
    body = r.json()
    assert set(body) == KEYS
    assert body["Value"] == [1]
    assert body["ClientTransactionID"] == CTID and body["ServerTransactionID"] == 1


def test_description(alpaca: Alpaca) -> None:
    body = get(alpaca, "/management/v1/description", {"clienttransactionid": "9"}).json()
    assert body["Value"] == {"ServerName": SERVER_INFO.server_name, "Manufacturer": SERVER_INFO.manufacturer,
                             "ManufacturerVersion": SERVER_INFO.manufacturer_version,
                             "Location": SERVER_INFO.location}
    assert body["ClientTransactionID"] == 9


def test_configured_devices(make_alpaca) -> None:
    first, second = StandInTelescope("AM5 north", "uid-a"), StandInTelescope("AM5 south", "uid-b")
    alpaca = make_alpaca([first, second])
    body = get(alpaca, "/management/v1/configureddevices").json()
    assert body["Value"] == [
        {"DeviceName": "AM5 north", "DeviceType": "Telescope", "DeviceNumber": 0, "UniqueID": "uid-a"},
        {"DeviceName": "AM5 south", "DeviceType": "Telescope", "DeviceNumber": 1, "UniqueID": "uid-b"},
    ]
    assert body["ClientTransactionID"] == 0
    first.device_name = "renamed"  # read per request, so a rename shows at once
    assert get(alpaca, "/management/v1/configureddevices").json()["Value"][0]["DeviceName"] == "renamed"


def test_management_shares_the_transaction_counter(alpaca: Alpaca) -> None:
    assert get(alpaca, "/management/apiversions").json()["ServerTransactionID"] == 1
    assert alpaca.http_get("canslew").json()["ServerTransactionID"] == 2
    assert get(alpaca, "/management/v1/description").json()["ServerTransactionID"] == 3


def test_management_touches_the_registry(alpaca: Alpaca) -> None:
    get(alpaca, "/management/apiversions", {"ClientID": "77"}, headers={"User-Agent": "finder"})
    [activity] = alpaca.registry.snapshot()
    assert activity.key == ClientKey("127.0.0.1", 77) and activity.user_agent == "finder"


@pytest.mark.parametrize(("key", "bad"), [("ClientID", ""), ("ClientID", "-1"), ("ClientTransactionID", "x"),
                                          ("clienttransactionid", "4294967296")])
def test_bad_ids_are_400(alpaca: Alpaca, key: str, bad: str) -> None:
    r = get(alpaca, "/management/v1/description", {key: bad})
    assert r.status_code == 400 and r.headers["Content-Type"].startswith("text/plain")


@pytest.mark.parametrize(("path", "status"), [
    ("/management/v1/nosuchthing", 403),
    ("/management/v1/Description", 403),
    ("/management/v1/", 403),
    ("/management/v2/description", 400),
    ("/management/apiversion", 400),
    ("/management", 400),
    ("/MANAGEMENT/apiversions", 400),
])
def test_bad_management_paths(alpaca: Alpaca, path: str, status: int) -> None:
    r = get(alpaca, path)
    assert r.status_code == status
    assert r.headers["Content-Type"].startswith("text/plain")


@pytest.mark.parametrize("verb", ["PUT", "POST", "DELETE"])
def test_management_is_get_only(alpaca: Alpaca, verb: str) -> None:
    r = alpaca.session.request(verb, alpaca.base + "/management/apiversions", timeout=10)
    assert r.status_code == 405 and "GET" in r.headers["Allow"]
