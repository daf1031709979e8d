"""Errors in a person's words (issue 43 point 6): what happened and what to do next, never an errno, an Alpaca
member's advice to programs or the settings file's own name for where the value came from."""

from __future__ import annotations

import dataclasses

import pytest

from alpaca_zwo.server import AlpacaZwoServer
from tests.conftest import ServerFactory, make_settings
from tests.web.test_setup_api import TIMEOUT, Client

MISSING = "/dev/ttyNO-MOUNT-HERE"


@pytest.fixture
def missing_mount(server_factory: ServerFactory) -> AlpacaZwoServer:
    settings = make_settings()
    return server_factory(dataclasses.replace(settings, devices=(dataclasses.replace(settings.devices[0],
                                                                                    url=MISSING),)))


def test_a_mount_not_found_says_where_it_was_looked_for_and_what_to_check(missing_mount: AlpacaZwoServer) -> None:
    client = Client(f"http://127.0.0.1:{missing_mount.port}")
    r = client.post("/setup/api/telescope/0/action/connect")
    assert r.status_code == 409
    said = r.json()["error"]
    assert said.startswith(f"No mount answered on {MISSING}: check that the mount is switched on"), said
    assert "press Connect mount again" in said and "--list-devices" in said
    assert "Errno" not in said and "could not open port" not in said
    # Programs still get the driver's own words (ASCOM: the error's number and text are theirs to log).
    r = client.session.put(f"{client.base}/api/v1/telescope/0/connected", data={"Connected": "true", "ClientID": "5"},
                           timeout=TIMEOUT)
    assert r.json()["ErrorNumber"] == 0x500 and MISSING in r.json()["ErrorMessage"]


def test_the_page_is_told_to_press_connect_not_to_set_connected(client: Client) -> None:
    r = client.post("/setup/api/telescope/0/action/tracking", {"on": True})
    assert r.status_code == 409
    said = r.json()["error"]
    assert "press Connect mount first" in said and "Connected=true" not in said and "Connect first" not in said, said


def test_a_settings_refusal_does_not_name_its_own_source(client: Client) -> None:
    r = client.post("/setup/api/telescope/0/settings", {"limits": {"horizon": [[0, 10], [90, 95]]}})
    assert r.status_code == 400
    said = r.json()["error"]
    assert said.startswith("limits.horizon: point 1 altitude"), said  # the page turns this into its line number


def test_the_observatory_test_refuses_bad_input_in_words(client: Client) -> None:
    for body in ({}, {"role": "monitor"}, {"role": "monitor", "url": ""}, {"role": "weather", "url": "x:1/a"},
                 {"role": "monitor", "url": "192.168.1.30:11111/api/v1/dome/0"}, {"role": "roof", "url": 5},
                 {"role": "monitor", "url": "h:1/api/v1/safetymonitor/0", "extra": 1}):
        r = client.post("/setup/api/safety/test", body)
        assert r.status_code == 400, (body, r.text)
        assert r.json()["error"] and "setup page" not in r.json()["error"]


def test_a_device_url_without_its_scheme_is_plain_http(client: Client) -> None:
    """The observatory form's label writes host:port/api/v1/...: that is what people type (issue 43 point 9)."""
    saved = client.change({"safety": {"monitor": "127.0.0.1:9/api/v1/safetymonitor/0"}})
    assert saved["safety"]["monitor"] == "http://127.0.0.1:9/api/v1/safetymonitor/0"
    r = client.post("/setup/api/safety/test", {"role": "monitor", "url": "127.0.0.1:9/api/v1/safetymonitor/0"})
    assert r.status_code == 200 and r.json()["ok"] is False and r.json()["url"].startswith("http://127.0.0.1:9/")
    client.change({"safety": {"monitor": ""}})


@pytest.fixture
def client(base_url: str) -> Client:
    return Client(base_url)
