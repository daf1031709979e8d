"""The page's messages kept in the log (issue 43 point 1): the page shows only its newest message, so the
log is the history, refusals included, each on one line a person can read in the download."""

from __future__ import annotations

import logging

import pytest
import requests

from tests.web.test_setup_api import CSRF_HEADER, HEADERS, TIMEOUT, Client


@pytest.fixture
def client(base_url: str) -> Client:
    return Client(base_url)


def _log(client: Client) -> list[dict[str, object]]:
    entries: list[dict[str, object]] = client.session.get(f"{client.base}/setup/api/log", timeout=TIMEOUT).json()[
        "entries"]
    return entries


def test_a_refusal_the_page_showed_is_in_the_log_and_its_download(client: Client,
                                                                  caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.INFO, logger="alpaca_zwo")  # the server's default level (cli.py)
    said = "GoTo Omega Centauri refused: target is below the horizon limit"
    r = client.post("/setup/api/log", {"text": said, "level": "error"})
    assert r.status_code == 200, r.text
    entry = _log(client)[-1]
    assert entry["level"] == "WARNING" and entry["logger"] == "alpaca_zwo.page"
    assert str(entry["message"]).endswith(said)
    assert said in client.session.get(f"{client.base}/setup/api/log.txt", timeout=TIMEOUT).text
    r = client.post("/setup/api/log", {"text": "Tracking on."})
    assert r.status_code == 200 and _log(client)[-1]["level"] == "INFO"


def test_a_message_is_one_bounded_line(client: Client) -> None:
    forged = "first\n2026-12-02 00:00:00Z ERROR forged\x1b[31m line"
    r = client.post("/setup/api/log", {"text": forged, "level": "error"})
    assert r.status_code == 200, r.text
    message = str(_log(client)[-1]["message"])
    assert "\n" not in message and "\x1b" not in message and "first 2026-12-02" in message
    client.post("/setup/api/log", {"text": "x" * 5000, "level": "info"})
    assert len(str(_log(client)[-1]["message"])) < 700


def test_bad_input_is_refused_in_words_never_500(client: Client) -> None:
    for body in ({}, {"text": ""}, {"text": "  "}, {"text": 5}, {"text": "ok", "level": "panic"}, {"text": ["a"]}):
        r = client.post("/setup/api/log", body)
        assert r.status_code == 400, (body, r.text)
        assert r.json()["error"]
    r = client.session.post(f"{client.base}/setup/api/log", data="{", headers=HEADERS, timeout=TIMEOUT)
    assert r.status_code == 400
    r = client.session.post(f"{client.base}/setup/api/log", data="x" * 10000, headers=HEADERS, timeout=TIMEOUT)
    assert r.status_code == 413


def test_another_site_cannot_write_the_log(client: Client) -> None:
    before = _log(client)
    r = requests.post(f"{client.base}/setup/api/log", json={"text": "forged"}, timeout=TIMEOUT)
    assert r.status_code == 403
    r = client.post("/setup/api/log", {"text": "forged"},
                    headers={CSRF_HEADER: "1", "Origin": "http://evil.example", "Content-Type": "application/json"})
    assert r.status_code == 403
    assert not any("forged" in str(e["message"]) for e in _log(client)[len(before):])
