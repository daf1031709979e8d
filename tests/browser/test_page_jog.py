"""The jog pad (issue 43 point 10), in real Chromium at 390x844 (night mode, Sydney) and 1280x900 (Greenwich):
it says "hold", a tap steps an amount that shows (judged by the emulator's Dec axis on a real-time clock), it
faces the way the chart does (in the south the chart faces north: east on the right, north at the bottom), and
the position is beside it on a phone."""

from __future__ import annotations

import pytest
from selenium.webdriver.common.by import By
from selenium.webdriver.remote.webdriver import WebDriver
from selenium.webdriver.support.ui import WebDriverWait

from alpaca_zwo.config.settings import EmulatorSettings, SiteSettings
from alpaca_zwo.sky import SIDEREAL_DEG_S
from tests.browser.test_page_handset import SIZES, TIMEOUT
from tests.conftest import ServerFactory, make_settings
from tests.support import wait_until
from tests.web.test_setup_api import Client


def _box(driver: WebDriver, element_id: str) -> dict[str, float]:
    return dict(driver.execute_script(
        "const r = document.getElementById(arguments[0]).getBoundingClientRect();"
        " return {left: r.left, right: r.right, top: r.top, bottom: r.bottom, x: r.left + r.width / 2,"
        " y: r.top + r.height / 2};", element_id))


@pytest.mark.parametrize(("size", "latitude"), [("phone", -33.8688), ("desktop", 51.4769)])
def test_the_pad_says_hold_steps_on_a_tap_faces_the_chart_and_shows_the_position(
        server_factory: ServerFactory, browser: WebDriver, size: str, latitude: float) -> None:
    server = server_factory(make_settings(site=SiteSettings(latitude=latitude, longitude=151.2, elevation=40.0),
                                          emulator=EmulatorSettings(speed=1.0, baud=0)))  # a real-time step
    client = Client(f"http://127.0.0.1:{server.port}")
    client.command("connected", Connected="true")
    wait_until(lambda: client.status()["position"] is not None, what="a first position")
    browser.set_window_size(*SIZES[size])
    browser.get(f"http://127.0.0.1:{server.port}/setup")
    if size == "phone":
        browser.execute_script("localStorage.setItem('alpaca-zwo-night', '1')")
        browser.refresh()
    WebDriverWait(browser, TIMEOUT).until(lambda d: d.find_element(By.ID, "jog-n").is_enabled())
    south = latitude < 0
    facing = "east on the right" if south else "east on the left"
    WebDriverWait(browser, TIMEOUT).until(lambda d: facing in d.find_element(By.ID, "sky-orientation").text)
    east, west, north, south_key = (_box(browser, f"jog-{k}") for k in "ewns")
    assert (east["x"] > west["x"]) == south, (east, west)  # E on the chart's east side
    assert (north["y"] > south_key["y"]) == south, (north, south_key)  # N towards the chart's north
    assert browser.find_element(By.ID, "jog-hint").text == "Hold a direction to move; a tap steps about 5\u2032."

    # A tap: one click, released at once, moves 1 s at 20x sidereal (5'), then stops by itself.
    browser.execute_script("document.getElementById('jog').scrollIntoView({block: 'center'})")
    before = client.value("declination")
    browser.find_element(By.ID, "jog-n").click()
    wait_until(lambda: client.value("slewing"), TIMEOUT, "the step to start")
    wait_until(lambda: not client.value("slewing"), TIMEOUT, "the step to end")
    moved = abs(client.value("declination") - before)
    step = 20 * SIDEREAL_DEG_S
    assert 0.7 * step < moved < 1.5 * step, (moved, step)

    # The position beside the pad, in view with it.
    WebDriverWait(browser, TIMEOUT).until(lambda d: "Dec " in d.find_element(By.ID, "jog-pos").text)
    pad, pos = _box(browser, "jog"), _box(browser, "jog-pos")
    inner = browser.execute_script("return [window.innerWidth, window.innerHeight]")
    assert pos["left"] >= 0 and pos["right"] <= inner[0] and pos["top"] < pad["bottom"] and pos["bottom"] > pad["top"]
    assert pos["left"] >= pad["right"], (pos, pad)  # beside it, not under it
    browser.save_screenshot(f"/tmp/alpaca-zwo-jog-{size}.png")
