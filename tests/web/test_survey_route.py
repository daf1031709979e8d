"""The page's survey over HTTP (issue 39 item 5), against a real server on the built-in emulator.

``POST /setup/api/telescope/{n}/survey`` runs the read-only survey through the server's own link (queued
like a poll), refuses in words when the mount is not connected or is moving, and keeps the report for
``GET …/survey.txt``; nothing the survey sends changes the emulated mount.
"""

from __future__ import annotations

from typing import Any

from alpaca_zwo.config.settings import EmulatorSettings
from alpaca_zwo.server import AlpacaZwoServer, Overrides
from alpaca_zwo.zwo.survey import SURVEY_COMMANDS
from tests.conftest import ServerFactory, make_settings
from tests.faults.harness import MountRecorder
from tests.support import wait_until
from tests.web.test_setup_api import TIMEOUT, Client

ROUTE = "/setup/api/telescope/0/survey"


def _start(server_factory: ServerFactory, preset: str | None = None) -> tuple[AlpacaZwoServer, Client]:
    server = server_factory(make_settings(emulator=EmulatorSettings(speed=1.0, baud=0)),
                            Overrides(emulator_preset=preset))
    return server, Client(f"http://127.0.0.1:{server.port}")


def _connect(client: Client) -> None:
    client.command("connected", Connected="true")
    wait_until(lambda: client.status()["position"] is not None, what="a first position")


def _verdicts(body: dict[str, Any]) -> dict[str, dict[str, Any]]:
    return {v["switch"]: v for v in body["verdicts"]}


def test_survey_of_a_connected_mount_names_its_preset_and_offers_the_report(server_factory: ServerFactory) -> None:
    server, client = _start(server_factory, "am5n-1.6.3")
    _connect(client)
    emulator = server.emulators[0]
    assert emulator is not None
    recorder = MountRecorder(emulator.server)
    try:
        r = client.post(ROUTE)
    finally:
        recorder.uninstall()
    assert r.status_code == 200, r.text
    body = r.json()
    assert body["mount"].startswith("AM5N firmware 1.6.3") and body["exchanges"] == len(SURVEY_COMMANDS)
    verdicts = _verdicts(body)
    assert verdicts["gmza_south_azimuth"] == {"switch": "gmza_south_azimuth", "state": "settled", "values": [True],
                                              "line": "gmza_south_azimuth = True (from :GU#, :GZ#, :GMZA#)"}
    assert verdicts["model"]["values"] == ["AM5N"] and verdicts["hp_reply"]["state"] == "open"
    received = {exchange.body for exchange in recorder.all()}
    assert set(SURVEY_COMMANDS) <= received  # every question reached the mount (the poller's reads beside them)
    link = client.status()["link"]
    assert link["state"] == "connected" and link["timeouts"] == 0 and not link["poll_error"], link
    wait_until(lambda: client.status()["link"]["exchanges"] > link["exchanges"], what="the poller reading on")

    download = client.session.get(f"{client.base}{ROUTE}.txt", timeout=TIMEOUT)
    assert download.status_code == 200 and download.headers["Content-Type"].startswith("text/plain")
    assert 'attachment; filename="alpaca-zwo-survey-' in download.headers["Content-Disposition"]
    assert "connection: the built-in emulator, preset am5n-1.6.3" in download.text
    assert "gmza_south_azimuth = True" in download.text


def test_no_survey_before_connecting_and_no_report_before_a_survey(server_factory: ServerFactory) -> None:
    _server, client = _start(server_factory)
    r = client.post(ROUTE)
    assert r.status_code == 409 and "connect the mount first" in r.json()["error"]
    r = client.session.get(f"{client.base}{ROUTE}.txt", timeout=TIMEOUT)
    assert r.status_code == 404 and "no survey yet" in r.json()["error"]


def test_survey_is_refused_in_words_while_the_mount_moves(server_factory: ServerFactory) -> None:
    _server, client = _start(server_factory)
    _connect(client)
    client.action("move", {"axis": 0, "rate": 1.0})
    try:
        r = client.post(ROUTE)
        assert r.status_code == 409, r.text
        assert "survey not run: the mount is" in r.json()["error"]
    finally:
        client.action("abort")
    wait_until(lambda: client.post(ROUTE).status_code == 200, what="a survey once the mount is at rest")


def test_survey_without_the_page_header_is_refused(server_factory: ServerFactory) -> None:
    _server, client = _start(server_factory)
    r = client.post(ROUTE, headers={})
    assert r.status_code == 403
