"""A web page in real Chromium against the bridge ports (issue 32): nothing it sends drives the mount.

The attack: a page on any web site runs ``fetch("http://<pi>:4030/", {method: "POST", mode: "no-cors",
body: ":Sr..#:Sd..#:MS#"})``; no-cors needs no permission, so Chromium writes the request line,
headers and body into the ZWO port (and into Stellarium's the same way). ``--host-resolver-rules``
maps evil.example to 127.0.0.1 as in the rebinding test; the attacker's page is served by the test's
own small web server (with no Content-Security-Policy, unlike the setup page), so it is on a foreign
origin and reaches the ports both by that name and by address. Judged by the emulator's truth (no motion, no
tracking, site unchanged) and the settings file's bytes; the same body from a real driver's socket
does move the mount, so the test would see an attack that got through.
"""

from __future__ import annotations

import socket
import threading
from collections.abc import Callable, Iterator
from http.server import BaseHTTPRequestHandler, ThreadingHTTPServer
from pathlib import Path
from typing import Any

import pytest

from alpaca_zwo.config.settings import StellariumSettings, ZwoPortSettings
from alpaca_zwo.server import AlpacaZwoServer
from tests.bridges.test_zwo_port_door import hold_connected, write_settings_file
from tests.conftest import make_settings
from tests.support import wait_until

TIMEOUT = 10
EVIL = "evil.example"
#: A GOTO, a manual move, tracking on and a new site: every kind of change the port would make.
BODY = ":Sr03:00:00#:Sd+20*00:00#:MS#:Me#:Te#:St+10*00#:Sg+020*00#"

#: What the attacking page runs: no-cors requests of every kind a page can make without permission.
ATTACK = """
const [urls, body, done] = arguments;
const results = [];
for (const url of urls) {
  for (const init of [{method: "POST", mode: "no-cors", body},
                      {method: "POST", mode: "no-cors", body, headers: {"Content-Type": "text/plain"}},
                      {method: "GET", mode: "no-cors"}]) {
    init.signal = AbortSignal.timeout(3000);  // a port that kept the connection would leave it hanging
    try {
      const r = await fetch(url + "?" + encodeURIComponent(body), init);
      results.push([url, init.method, "answered " + r.type]);
    } catch (e) {
      results.push([url, init.method, String(e)]);
    }
  }
}
done(results);
"""


class _AttackerSite(BaseHTTPRequestHandler):
    """evil.example's web server: one plain page, no security headers."""

    def do_GET(self) -> None:
        page = b"<!doctype html><title>innocent page</title><p>nothing to see here</p>"
        self.send_response(200)
        self.send_header("Content-Type", "text/html; charset=utf-8")
        self.send_header("Content-Length", str(len(page)))
        self.end_headers()
        self.wfile.write(page)

    def log_message(self, format: str, *args: Any) -> None:
        pass


@pytest.fixture
def attacker_port() -> Iterator[int]:
    site = ThreadingHTTPServer(("127.0.0.1", 0), _AttackerSite)
    thread = threading.Thread(target=site.serve_forever, daemon=True)
    thread.start()
    yield int(site.server_address[1])
    site.shutdown()
    site.server_close()


def test_a_pages_no_cors_posts_to_the_bridge_ports_change_nothing(
        browser_factory: Callable[..., Any], server_factory: Callable[..., AlpacaZwoServer], tmp_path: Path,
        attacker_port: int) -> None:
    server = server_factory(make_settings(
        zwo_port=ZwoPortSettings(enabled=True, host="127.0.0.1", port=0),
        stellarium=StellariumSettings(enabled=True, host="127.0.0.1", port=0, equinox="JNow")))
    model = server.emulators[0].model  # type: ignore[union-attr]
    hold_connected(server)
    write_settings_file(server)
    config = tmp_path / "config.toml"
    before = config.read_bytes()
    site = (model.snapshot()["latitude"], model.snapshot()["longitude_east"])
    zwo, stellarium = server.zwo_port.port, server.stellarium.port

    driver = browser_factory(f"--host-resolver-rules=MAP {EVIL} 127.0.0.1")
    driver.set_script_timeout(60)
    driver.get(f"http://{EVIL}:{attacker_port}/")  # the attacker's page
    assert driver.execute_script("return location.origin") == f"http://{EVIL}:{attacker_port}"
    urls = [f"http://{host}:{port}/" for port in (zwo, stellarium) for host in (EVIL, "127.0.0.1")]
    results = driver.execute_async_script(ATTACK, urls, BODY)
    assert len(results) == 12

    polled = server.telescopes[0].mount.state.position_time
    wait_until(lambda: server.telescopes[0].mount.state.position_time != polled, TIMEOUT, "a fresh poll")
    truth = model.snapshot()
    assert truth["moves_deg_s"] == [None, None] and truth["slew"] is None and truth["tracking"] is False
    assert (truth["latitude"], truth["longitude_east"]) == site
    assert config.read_bytes() == before
    for url, method, outcome in results:  # every connection closed unanswered: a network error in the page
        assert outcome == "TypeError: Failed to fetch", (url, method, outcome)
    zwo_status, stellarium_status = server.zwo_port.status(), server.stellarium.status()
    assert zwo_status["programs"] == [] and zwo_status["last_command"] is None
    assert stellarium_status["clients"] == [] and stellarium_status["last_command"] is None
    assert zwo_status["turned_away"] >= 6 and stellarium_status["turned_away"] >= 6  # Chromium may retry some
    assert "not a ZWO command" in zwo_status["last_turned_away"]["reason"]
    assert "not Stellarium's protocol" in stellarium_status["last_turned_away"]["message"]

    # The same body from a driver's socket is obeyed: the refusals above were the door's.
    with socket.create_connection(("127.0.0.1", zwo), timeout=TIMEOUT) as sock:
        sock.sendall(b":Te#:Me#")
        wait_until(lambda: model.snapshot()["moves_deg_s"][0] is not None, TIMEOUT, "the driver's move")
        sock.sendall(b":Q#")
    wait_until(lambda: model.snapshot()["tracking"] is True, TIMEOUT, "the driver's tracking")


def test_the_page_shows_and_edits_the_bridge_networks(browser_factory: Callable[..., Any],
                                                      server_factory: Callable[..., AlpacaZwoServer]) -> None:
    from selenium.webdriver.common.by import By
    from selenium.webdriver.support.ui import WebDriverWait

    server = server_factory(make_settings(zwo_port=ZwoPortSettings(enabled=True, host="127.0.0.1", port=0)))
    driver = browser_factory()
    driver.get(f"http://127.0.0.1:{server.port}/setup")
    WebDriverWait(driver, 15).until(lambda d: d.find_element(By.ID, "link-pill").text.startswith("mount:"))
    zwo_field, stellarium_field = (driver.find_element(By.ID, i) for i in ("n-zwo-networks", "n-stellarium-networks"))
    assert zwo_field.get_attribute("value") == "local" == stellarium_field.get_attribute("value")
    local = driver.find_element(By.ID, "networks-local").text
    assert "127.0.0.0/8" in local and "::1/128" in local

    zwo_field.clear()
    zwo_field.send_keys("local\n10.8.0.0/24")
    stellarium_field.clear()
    stellarium_field.send_keys("192.168.1.20")
    driver.find_element(By.CSS_SELECTOR, "#form-networks button[type=submit]").click()
    WebDriverWait(driver, TIMEOUT).until(lambda d: "Bridge networks saved" in d.find_element(By.ID, "messages").text)
    assert server.settings.zwo_port.allowed_networks == ("local", "10.8.0.0/24")
    assert server.settings.stellarium.allowed_networks == ("192.168.1.20",)
    assert "10.8.0.0/24" in server.zwo_port.status()["allowed_networks"]  # the running bridge follows at once

    zwo_field.clear()
    zwo_field.send_keys("not-a-network")
    driver.find_element(By.CSS_SELECTOR, "#form-networks button[type=submit]").click()
    WebDriverWait(driver, TIMEOUT).until(lambda d: "'not-a-network' is not a network" in  # beside its form
                                         d.find_element(By.CSS_SELECTOR, "#form-networks + .refusal").text)
    assert server.settings.zwo_port.allowed_networks == ("local", "10.8.0.0/24")
