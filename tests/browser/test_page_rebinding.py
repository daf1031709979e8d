"""DNS rebinding in real Chromium: the setup page opened by a foreign name can change nothing.

``--host-resolver-rules`` makes Chromium resolve evil.example (and this machine's ``.local`` name)
to 127.0.0.1, exactly what a rebinding attacker's DNS does: the page at http://evil.example:PORT
is then same-origin with the server for the browser. Its own requests (the page's start-up
reads, a clicked control, and a script's fetches with the X-Alpaca-Zwo header) must all be
refused, the mount must not move (the emulator's truth) and the settings file must keep its bytes.
The same page by 127.0.0.1 and by ``<hostname>.local`` works.
"""

from __future__ import annotations

import json
import socket
from collections.abc import Callable
from pathlib import Path
from typing import Any

import requests
from selenium.webdriver.common.action_chains import ActionChains
from selenium.webdriver.common.by import By
from selenium.webdriver.remote.webdriver import WebDriver
from selenium.webdriver.support.ui import WebDriverWait

from alpaca_zwo.server import AlpacaZwoServer
from tests.support import AlpacaClient, wait_until

TIMEOUT = 10
EVIL = "evil.example"
LOCAL_NAME = socket.gethostname().split(".")[0].lower() + ".local"

#: The page's own request helpers, called from the page's origin (what a rebinding script would run).
FETCH = """
const [method, path, body, form, done] = arguments;
const headers = form ? {"Content-Type": "application/x-www-form-urlencoded"}
                     : {"Content-Type": "application/json", "X-Alpaca-Zwo": "1"};
fetch(path, {method, headers, body: method === "GET" ? undefined : body, credentials: "same-origin"})
  .then(async (r) => done([r.status, await r.text()]))
  .catch((e) => done([0, String(e)]));
"""


def fetch(driver: WebDriver, method: str, path: str, body: object = None, *,
          form: str | None = None) -> tuple[int, str]:
    """Run a fetch in the page (its origin, its cookies); (status, body text)."""
    payload = form if form is not None else json.dumps(body or {})
    status, text = driver.execute_async_script(FETCH, method, path, payload, form is not None)
    return status, text


def messages(driver: WebDriver) -> str:
    """What the page says: its message place and the refusals beside the controls that caused them."""
    return str(driver.execute_script(
        "return [...document.querySelectorAll('#messages, .refusal')].map((e) => e.innerText).join('\\n')"))


def test_page_by_a_rebound_name_is_refused_and_moves_nothing(browser_factory: Callable[..., Any],
                                                              server_factory: Callable[..., AlpacaZwoServer],
                                                              tmp_path: Path) -> None:
    server = server_factory()
    port = server.port
    model = server.emulators[0].model  # type: ignore[union-attr]
    alpaca = AlpacaClient(port, timeout=TIMEOUT, call_timeout=TIMEOUT)
    alpaca.command("connected", Connected="true")  # a connected mount, so a move that got through would move
    alpaca.command("tracking", Tracking="false")
    # Write the settings file once (from this machine), so the attack has bytes to change.
    r = requests.post(f"http://127.0.0.1:{port}/setup/api/server", json={"location": "backyard"},
                      headers={"X-Alpaca-Zwo": "1"}, timeout=TIMEOUT)
    assert r.status_code == 200, r.text
    config = tmp_path / "config.toml"
    before = config.read_bytes()
    latitude = model.snapshot()["latitude"]

    driver = browser_factory(f"--host-resolver-rules=MAP {EVIL} 127.0.0.1, MAP {LOCAL_NAME} 127.0.0.1")
    driver.set_script_timeout(TIMEOUT)
    driver.get(f"http://{EVIL}:{port}/setup")
    assert driver.title == "alpaca-zwo setup"  # the page itself is served; its API calls are not
    WebDriverWait(driver, TIMEOUT).until(lambda d: "server.allowed_hosts" in messages(d))
    assert f"Refused: host '{EVIL}' is not allowed" in messages(driver)
    assert f"add '{EVIL}' to server.allowed_hosts on the setup page" in messages(driver)

    # Controls clicked in the page: Tracking on, and a held jog button.
    driver.find_element(By.ID, "btn-track-on").click()
    WebDriverWait(driver, TIMEOUT).until(lambda d: "Tracking did not turn on: Refused" in messages(d))  # beside it
    jog = driver.find_element(By.ID, "jog-n")
    ActionChains(driver).click_and_hold(jog).perform()
    WebDriverWait(driver, TIMEOUT).until(lambda d: "The move did not start: Refused" in messages(d))  # the newest only
    ActionChains(driver).release(jog).perform()

    # What a rebinding script would send, with the page's own header, from the page's origin.
    attacks: list[tuple[str, str, object, str | None]] = [
        ("POST", "/setup/api/telescope/0/action/move", {"axis": 0, "rate": 4.0}, None),
        ("POST", "/setup/api/telescope/0/action/tracking", {"on": True}, None),
        ("POST", "/setup/api/telescope/0/settings", {"site": {"latitude": -33.9, "longitude": 151.2}}, None),
        ("POST", "/setup/api/telescope/0/settings", {"safety": {"moveaxis_watchdog_s": 600}}, None),
        ("POST", "/setup/api/server", {"host": "203.0.113.9"}, None),
        ("POST", "/setup/api/server", {"allowed_hosts": ["*"]}, None),
        ("GET", "/setup/api/telescope/0/settings", None, None),
        ("GET", "/setup/api/log", None, None),
        ("GET", "/setup/api/telescope/0/trace", None, None),
        ("PUT", "/api/v1/telescope/0/moveaxis", None, "ClientID=9&Axis=1&Rate=4"),
        ("PUT", "/api/v1/telescope/0/tracking", None, "ClientID=9&Tracking=true"),
        ("GET", "/api/v1/telescope/0/sitelatitude", None, None),
    ]
    for method, path, body, form in attacks:
        status, text = fetch(driver, method, path, body, form=form)
        assert status == 403, (method, path, status, text)
        assert text.startswith(f"Refused: host '{EVIL}'") and text.count("\n") == 1, text

    # Nothing moved, nothing changed: judged after a poll that started after every attempt.
    polled = server.telescopes[0].mount.state.position_time
    wait_until(lambda: server.telescopes[0].mount.state.position_time != polled, TIMEOUT, "a fresh poll")
    truth = model.snapshot()
    assert truth["moves_deg_s"] == [None, None] and truth["slew"] is None and truth["tracking"] is False
    assert truth["latitude"] == latitude
    assert config.read_bytes() == before

    # The same page by IP address and by <hostname>.local works, requests and controls alike.
    for name in ("127.0.0.1", LOCAL_NAME):
        driver.get(f"http://{name}:{port}/setup")
        WebDriverWait(driver, 15).until(lambda d: d.find_element(By.ID, "link-pill").text.startswith("mount:"))
        assert "Refused" not in messages(driver)
        status, text = fetch(driver, "GET", "/setup/api/telescope/0/settings")
        assert status == 200, text
    driver.find_element(By.ID, "btn-track-on").click()
    WebDriverWait(driver, TIMEOUT).until(lambda d: model.snapshot()["tracking"] is True)
    status, text = fetch(driver, "POST", "/setup/api/telescope/0/action/move", {"axis": 0, "rate": 1.0})
    assert status == 200, text
    wait_until(lambda: model.snapshot()["moves_deg_s"][0] is not None, TIMEOUT, "the page's move by its own name")
    status, text = fetch(driver, "POST", "/setup/api/telescope/0/action/move", {"axis": 0, "rate": 0.0})
    assert status == 200, text


def test_star_in_allowed_hosts_shows_a_warning(browser_factory: Callable[..., Any],
                                               server_factory: Callable[..., AlpacaZwoServer]) -> None:
    """The list is edited on the page; "*" (no guard) puts a visible warning on the page."""
    server = server_factory()
    driver = browser_factory(f"--host-resolver-rules=MAP {EVIL} 127.0.0.1")
    driver.get(f"http://127.0.0.1:{server.port}/setup")
    WebDriverWait(driver, 15).until(lambda d: d.find_element(By.ID, "link-pill").text.startswith("mount:"))
    warning = driver.find_element(By.ID, "hosts-warning")
    assert not warning.is_displayed()
    assert LOCAL_NAME in driver.find_element(By.ID, "hosts-always").text

    field = driver.find_element(By.ID, "n-hosts")
    field.clear()
    field.send_keys(f"{EVIL}\n*")
    driver.find_element(By.CSS_SELECTOR, "#form-hosts button[type=submit]").click()
    WebDriverWait(driver, TIMEOUT).until(lambda d: "Allowed host names saved" in messages(d))
    assert server.settings.server.allowed_hosts == (EVIL, "*")
    assert warning.is_displayed() and "DNS rebinding is off" in warning.text
    # In effect at once: the page by the foreign name now works (no restart).
    driver.get(f"http://{EVIL}:{server.port}/setup")
    WebDriverWait(driver, 15).until(lambda d: d.find_element(By.ID, "link-pill").text.startswith("mount:"))
    assert driver.find_element(By.ID, "hosts-warning").is_displayed()

    field = driver.find_element(By.ID, "n-hosts")
    field.clear()
    driver.find_element(By.CSS_SELECTOR, "#form-hosts button[type=submit]").click()
    WebDriverWait(driver, TIMEOUT).until(lambda d: "Allowed host names saved" in messages(d))
    assert server.settings.server.allowed_hosts == ()
    assert not driver.find_element(By.ID, "hosts-warning").is_displayed()
