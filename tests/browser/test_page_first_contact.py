"""First contact in real Chromium (issue 25 item 5), at phone (390x844) and desktop (1280x900) widths.

- The page names the mount it really drives: a ``--device`` URL (here an emulator on its own TCP
  port, to the server a mount on WiFi) is shown as that URL, never as "built-in emulator".
- Alt/Az are shown in degrees, minutes and seconds like Dec, equal to the status feed's values.
- Opened by ``<hostname>.local`` (an http page that is not a secure context, as from a phone),
  "Use this browser's location" explains why the browser will not tell it and what to do instead.
"""

from __future__ import annotations

import re
import socket
from collections.abc import Callable, Iterator
from typing import Any

import pytest
import requests
from selenium.webdriver.common.by import By
from selenium.webdriver.remote.webdriver import WebDriver
from selenium.webdriver.support.ui import WebDriverWait

from alpaca_zwo.emulator import EmulatorServer, MountModel, ScaledClock
from alpaca_zwo.server import AlpacaZwoServer, Overrides
from tests.support import AlpacaClient

TIMEOUT = 15
SIZES = {"phone": (390, 844), "desktop": (1280, 900)}
LOCAL_NAME = socket.gethostname().split(".")[0].lower() + ".local"
DMS_ALT = re.compile(r"([+\u2212])(\d{2,})\u00b0 (\d{2})\u2032 (\d{2})\u2033")
DMS_AZ = re.compile(r"(\d{3})\u00b0 (\d{2})\u2032 (\d{2})\u2033")


def text(driver: WebDriver, element_id: str) -> str:
    return driver.find_element(By.ID, element_id).text


def open_page(driver: WebDriver, url: str, size: tuple[int, int]) -> None:
    driver.set_window_size(*size)
    driver.get(url)
    WebDriverWait(driver, TIMEOUT).until(lambda d: text(d, "link-pill").startswith("mount:"))


@pytest.fixture
def external_mount() -> Iterator[str]:
    """An emulator on its own TCP port: to the server, a real mount at a socket:// URL (its WiFi)."""
    emulator = EmulatorServer(MountModel(ScaledClock()), host="127.0.0.1", port=0, baud=0).start()
    yield f"socket://127.0.0.1:{emulator.port}"
    emulator.stop()


@pytest.mark.parametrize("size", ["phone", "desktop"])
def test_page_names_the_mount_at_the_device_url(browser: WebDriver, server_factory: Callable[..., AlpacaZwoServer],
                                                 external_mount: str, size: str) -> None:
    server = server_factory(None, Overrides(device_url=external_mount))
    AlpacaClient(server.port, timeout=TIMEOUT, call_timeout=TIMEOUT).command("connected", Connected="true")
    open_page(browser, f"http://127.0.0.1:{server.port}/setup", SIZES[size])
    WebDriverWait(browser, TIMEOUT).until(lambda d: text(d, "mount").startswith("ZWO"))
    assert external_mount in text(browser, "mount"), text(browser, "mount")
    assert external_mount in text(browser, "link")
    assert browser.find_element(By.ID, "d-url").get_attribute("value") == external_mount
    page = browser.find_element(By.TAG_NAME, "body").text
    assert "emulator" not in page.lower(), "a real mount called an emulator"
    browser.save_screenshot(f"/tmp/alpaca-zwo-first-contact-device-{size}.png")


def test_page_names_the_built_in_emulator(browser: WebDriver, server_factory: Callable[..., AlpacaZwoServer]) -> None:
    server = server_factory()
    AlpacaClient(server.port, timeout=TIMEOUT, call_timeout=TIMEOUT).command("connected", Connected="true")
    open_page(browser, f"http://127.0.0.1:{server.port}/setup", SIZES["desktop"])
    WebDriverWait(browser, TIMEOUT).until(lambda d: text(d, "mount").startswith("ZWO"))
    assert text(browser, "mount").endswith("built-in emulator"), text(browser, "mount")
    assert browser.find_element(By.ID, "d-url").get_attribute("value") == "(built-in emulator)"


def _degrees(match: re.Match[str], signed: bool) -> float:
    groups = match.groups()
    sign = -1 if signed and groups[0] == "\u2212" else 1
    d, m, s = (int(g) for g in groups[1 if signed else 0:])
    return sign * (d + m / 60 + s / 3600)


@pytest.mark.parametrize("size", ["phone", "desktop"])
def test_alt_az_in_degrees_minutes_seconds(browser: WebDriver, server_factory: Callable[..., AlpacaZwoServer],
                                           size: str) -> None:
    server = server_factory()
    alpaca = AlpacaClient(server.port, timeout=TIMEOUT, call_timeout=TIMEOUT)
    alpaca.command("connected", Connected="true")
    alpaca.command("tracking", Tracking="false")  # Alt/Az stand still: the page and the feed must agree
    open_page(browser, f"http://127.0.0.1:{server.port}/setup", SIZES[size])
    WebDriverWait(browser, TIMEOUT).until(lambda d: DMS_ALT.fullmatch(text(d, "alt")) is not None)
    alt = DMS_ALT.fullmatch(text(browser, "alt"))
    az = DMS_AZ.fullmatch(text(browser, "az"))
    assert alt and az, (text(browser, "alt"), text(browser, "az"))
    status = requests.get(f"http://127.0.0.1:{server.port}/setup/api/telescope/0/status", timeout=TIMEOUT).json()
    assert abs(_degrees(alt, True) - status["position"]["alt"]) <= 1.5 / 3600, (alt.group(0), status["position"])
    assert abs(_degrees(az, False) - status["position"]["az"]) <= 1.5 / 3600, (az.group(0), status["position"])
    browser.save_screenshot(f"/tmp/alpaca-zwo-first-contact-altaz-{size}.png")


@pytest.mark.parametrize("size", ["phone", "desktop"])
def test_location_button_explains_an_insecure_page(browser_factory: Callable[..., Any],
                                                   server_factory: Callable[..., AlpacaZwoServer], size: str) -> None:
    server = server_factory()
    driver = browser_factory(f"--host-resolver-rules=MAP {LOCAL_NAME} 127.0.0.1")
    open_page(driver, f"http://{LOCAL_NAME}:{server.port}/setup", SIZES[size])
    assert driver.execute_script("return window.isSecureContext") is False
    note = driver.find_element(By.ID, "geo-note")
    # The button cannot work over http, so it is not offered; the note says why and what to do instead.
    assert not driver.find_element(By.ID, "btn-geo").is_displayed()
    WebDriverWait(driver, TIMEOUT).until(lambda d: note.is_displayed())
    explained = note.text
    for words in ("only with pages opened over https or as localhost", f"http://{LOCAL_NAME}:{server.port}",
                  "type the latitude and longitude", "phone's GPS"):
        assert words in explained, (words, explained)
    driver.execute_script("arguments[0].scrollIntoView({block: 'center'})", note)
    driver.save_screenshot(f"/tmp/alpaca-zwo-first-contact-location-{size}.png")


@pytest.mark.parametrize("size", ["phone", "desktop"])
def test_lost_link_gives_one_plain_message_and_greys_the_position(
        browser: WebDriver, server_factory: Callable[..., AlpacaZwoServer], size: str) -> None:
    """The mount on "WiFi" (a socket:// URL) goes away: what happened and what to try, no exception text,
    the last position kept but greyed out with its age (issue 25 item 4)."""
    emulator = EmulatorServer(MountModel(ScaledClock()), host="127.0.0.1", port=0, baud=0).start()
    try:
        server = server_factory(None, Overrides(device_url=f"socket://127.0.0.1:{emulator.port}"))
        AlpacaClient(server.port, timeout=TIMEOUT, call_timeout=TIMEOUT).command("connected", Connected="true")
        open_page(browser, f"http://127.0.0.1:{server.port}/setup", SIZES[size])
        WebDriverWait(browser, TIMEOUT).until(lambda d: DMS_ALT.fullmatch(text(d, "alt")) is not None)
        lost = browser.find_element(By.ID, "link-lost")
        assert not lost.is_displayed()
        assert "stale" not in (browser.find_element(By.ID, "readout").get_attribute("class") or "")
    finally:
        emulator.stop()  # the mount switched off / out of WiFi range
    WebDriverWait(browser, 30).until(lambda d: lost.is_displayed())
    message = lost.text
    assert message.startswith(("The connection to the mount is lost", "The mount has stopped")), message
    for words in ("switched on and has power", "WiFi", "keeps trying to reconnect", "last one known"):
        assert words in message, (words, message)
    status = requests.get(f"http://127.0.0.1:{server.port}/setup/api/telescope/0/status", timeout=TIMEOUT).json()
    raw = [e for e in (status["link"]["last_error"], status["link"]["poll_error"]) if e]
    assert raw, status["link"]  # the server does know the exception text ...
    body = browser.find_element(By.TAG_NAME, "body").text
    for error in raw:
        assert error not in body, error  # ... and the page does not show it
    assert "stale" in (browser.find_element(By.ID, "readout").get_attribute("class") or "")
    assert "stale" in (browser.find_element(By.ID, "sky").get_attribute("class") or "")
    for row in ("tracking", "park", "pier"):  # the mount's state is as old as its position
        assert "stale" in (browser.find_element(By.ID, row).get_attribute("class") or ""), row
    assert "stale" not in (browser.find_element(By.ID, "link").get_attribute("class") or "")
    assert float(browser.execute_script("return getComputedStyle(document.getElementById('readout')).opacity")) < 1
    assert DMS_ALT.fullmatch(text(browser, "alt")), text(browser, "alt")  # the last position, still shown
    assert "last known position" in text(browser, "age")
    assert body.count("The connection to the mount is lost") + body.count("The mount has stopped") == 1
    # STOP says it did not reach the mount, in plain words (the raw error stays in the log and trace)
    browser.find_element(By.ID, "btn-stop").click()
    WebDriverWait(browser, TIMEOUT).until(lambda d: "STOP: " in text(d, "messages"))
    said = text(browser, "messages")
    assert "did not reach it" in said and "power" in said, said
    assert "Errno" not in said and "socket://" not in said, said
    browser.execute_script("window.scrollTo(0, document.getElementById('status-h').getBoundingClientRect().top"
                           " + window.scrollY - 8)")
    browser.save_screenshot(f"/tmp/alpaca-zwo-first-contact-link-lost-{size}.png")


def test_phone_width_puts_the_hand_controller_first_and_never_scrolls_sideways(
        browser: WebDriver, server_factory: Callable[..., AlpacaZwoServer]) -> None:
    server = server_factory()
    AlpacaClient(server.port, timeout=TIMEOUT, call_timeout=TIMEOUT).command("connected", Connected="true")
    open_page(browser, f"http://127.0.0.1:{server.port}/setup", SIZES["phone"])
    overflow = browser.execute_script(
        "return document.documentElement.scrollWidth - document.documentElement.clientWidth")
    assert overflow <= 0, f"the page scrolls sideways by {overflow} px at phone width"
    stop = browser.find_element(By.CSS_SELECTOR, ".controls-card").rect["y"]
    status = browser.find_element(By.CSS_SELECTOR, ".status-card").rect["y"]
    assert stop < status, "at phone width the controls (STOP, Find object) come before the status"
