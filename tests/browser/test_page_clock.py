"""The page fixes a wrong clock end to end (issue 31.2), in real Chromium at phone width and in night mode.

The server runs under Debian's ``faketime -f -3h`` with its clock reported unsynchronised; the mount
(an emulator process with the true clock) has just been powered up, so it took the server's wrong
time at connect. Chromium, on the true clock, shows one line near the top and a button; pressing it
must set the server's and the mount's clocks right, judged by the emulator's truth.
"""

from __future__ import annotations

import socket
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
import requests
from selenium.webdriver.common.by import By
from selenium.webdriver.remote.webdriver import WebDriver
from selenium.webdriver.support.ui import WebDriverWait

from tests.support import AlpacaClient, EmulatorProcess
from tests.support.server import FAKETIME_ENV, ServerProcess
from tests.telescope.test_clock_in_the_field import goto_true_sky, mount_clock_error_s

TIMEOUT = 20
PHONE = (390, 844)
LOCAL_NAME = socket.gethostname().split(".")[0].lower() + ".local"


@pytest.fixture
def wrong_clock(tmp_path: Path) -> Iterator[tuple[EmulatorProcess, ServerProcess, AlpacaClient]]:
    mount = EmulatorProcess("--control-port", "0", "--baud", "0")
    server = None
    try:
        server = ServerProcess(tmp_path, "--device", f"socket://127.0.0.1:{mount.port()}",
                               wrapper=["faketime", "-f", "-3h"],
                               env={**FAKETIME_ENV, "ALPACA_ZWO_HOST_CLOCK": "unsynchronised"})
        client = AlpacaClient(server.port, 7, timeout=TIMEOUT)
        client.command("connected", Connected="true")
        yield mount, server, client
    finally:
        if server is not None:
            server.stop()
        mount.terminate()


def _visible(driver: WebDriver, element_id: str) -> bool:
    return bool(driver.find_element(By.ID, element_id).is_displayed())


def _open_at_phone_width_in_night_mode(driver: WebDriver, url: str) -> None:
    driver.set_window_size(*PHONE)
    driver.get(url)
    WebDriverWait(driver, TIMEOUT).until(lambda d: d.find_element(By.ID, "link-pill").text.startswith("mount:"))
    driver.find_element(By.ID, "btn-night").click()
    assert driver.execute_script("return document.documentElement.classList.contains('night')")


def test_use_this_devices_time_fixes_server_and_mount(
        browser: WebDriver, wrong_clock: tuple[EmulatorProcess, ServerProcess, AlpacaClient]) -> None:
    mount, server, client = wrong_clock
    assert mount_clock_error_s(mount) == pytest.approx(-10800, abs=2)  # the powered-up mount took the wrong time
    _open_at_phone_width_in_night_mode(browser, server.base_url + "/setup")
    line = browser.find_element(By.ID, "clock-line")
    WebDriverWait(browser, TIMEOUT).until(lambda d: "behind" in line.text)
    assert "The server's clock is 3 h 0 min behind this" in line.text, line.text
    button = browser.find_element(By.ID, "btn-device-time")
    assert button.is_displayed() and button.text == "Use this device's time"
    rect = button.rect  # near the top, wholly on a phone's screen, no scrolling needed
    assert rect["y"] + rect["height"] <= PHONE[1] and rect["x"] + rect["width"] <= PHONE[0], rect
    assert "rgb(0, 0, 0)" in browser.execute_script("return getComputedStyle(document.body).backgroundColor")
    browser.save_screenshot("/tmp/alpaca-zwo-clock-line-night-phone.png")

    button.click()
    WebDriverWait(browser, TIMEOUT).until(
        lambda d: "The mount's clock reads" in d.find_element(By.ID, "messages").text)
    assert abs(mount_clock_error_s(mount)) < 1.5, "the mount's clock was not set right"
    WebDriverWait(browser, TIMEOUT).until(lambda d: not _visible(d, "btn-device-time"))
    status = requests.get(server.base_url + "/setup/api/telescope/0/status", timeout=TIMEOUT).json()
    assert status["time"]["source"] == "client" and "setup page" in status["time"]["reason"]
    assert "set by a client or this page" in browser.find_element(By.ID, "time-source").text
    miss = goto_true_sky(client, mount, 2.0, 20.0)
    assert abs(miss) < 2.0, f"after the fix, a GOTO ended {miss:.1f} s of RA from its target on the true sky"


def test_the_line_offers_this_devices_position_while_the_site_is_default(
        browser_factory: Callable[..., Any], wrong_clock: tuple[EmulatorProcess, ServerProcess, AlpacaClient]) -> None:
    """As the Site form's button does, the line explains why an http page gets no position; on a secure
    page (localhost) the position this device reports becomes the site."""
    _, server, client = wrong_clock
    insecure = browser_factory(f"--host-resolver-rules=MAP {LOCAL_NAME} 127.0.0.1")
    _open_at_phone_width_in_night_mode(insecure, f"http://{LOCAL_NAME}:{server.port}/setup")
    WebDriverWait(insecure, TIMEOUT).until(lambda d: _visible(d, "field-note"))  # said at once, no button to try
    assert "still the default" in insecure.find_element(By.ID, "site-line").text
    assert not _visible(insecure, "btn-device-site")  # it cannot work over http (issue 43 point 4)
    said = insecure.find_element(By.ID, "field-note").text
    assert "only with pages opened over https or as localhost" in said and "longitude here" in said, said

    secure = browser_factory()
    origin = f"http://localhost:{server.port}"
    secure.execute_cdp_cmd("Browser.grantPermissions", {"origin": origin, "permissions": ["geolocation"]})
    secure.execute_cdp_cmd("Emulation.setGeolocationOverride",
                           {"latitude": -31.2733, "longitude": 149.0617, "accuracy": 5})
    _open_at_phone_width_in_night_mode(secure, origin + "/setup")
    WebDriverWait(secure, TIMEOUT).until(lambda d: _visible(d, "btn-device-site"))
    secure.find_element(By.ID, "btn-device-site").click()
    WebDriverWait(secure, TIMEOUT).until(lambda d: not _visible(d, "btn-device-site"))
    assert client.value("sitelatitude") == pytest.approx(-31.2733, abs=1e-6)
    assert client.value("sitelongitude") == pytest.approx(149.0617, abs=1e-6)
