"""Names kept, and the Moon's phase (issue 43 point 8), in real Chromium at 390x844 (night mode) and 1280x900,
at a Sydney site.

A person who searched "Omega Centauri" reads "Omega Centauri" on the card, in the GoTo message, on the progress
and arrival lines and in the log, with the catalogue's "NGC 5139" kept on the card's second line. The Moon's
card says its phase, checked against PyEphem at the server's instant."""

from __future__ import annotations

import logging
from datetime import datetime, timezone

import ephem
import pytest
from selenium.webdriver.common.by import By
from selenium.webdriver.remote.webdriver import WebDriver
from selenium.webdriver.support.ui import WebDriverWait

from tests.browser.test_page_handset import SLEW_TIMEOUT, TIMEOUT, Scene, button, shown, tap
from tests.conftest import ServerFactory

SYDNEY = -33.8688
NAME = "Omega Centauri"


@pytest.mark.parametrize("size", ["phone", "desktop"])
def test_the_name_searched_is_the_name_kept(server_factory: ServerFactory, browser: WebDriver, size: str,
                                           caplog: pytest.LogCaptureFixture) -> None:
    caplog.set_level(logging.INFO, logger="alpaca_zwo")  # the server's default level (cli.py)
    scene = Scene(server_factory, browser, size, NAME, latitude=SYDNEY)
    driver, client = scene.driver, scene.client
    scene.find(NAME, False)
    WebDriverWait(driver, TIMEOUT).until(lambda d: scene.selected() == NAME)
    assert "NGC 5139" in shown(driver, "sel-kind")
    tap(driver, button(driver, "GoTo"))
    WebDriverWait(driver, TIMEOUT).until(lambda d: f"GoTo {NAME} started." in d.find_element(By.ID, "messages").text)
    WebDriverWait(driver, TIMEOUT).until(lambda d: shown(d, "progress").startswith(f"Slewing to {NAME}"))
    WebDriverWait(driver, SLEW_TIMEOUT).until(lambda d: shown(d, "arrival").startswith(f"Arrived at {NAME}: "))
    logged = [str(e["message"]) for e in
              client.session.get(f"{client.base}/setup/api/log", timeout=TIMEOUT).json()["entries"]]
    assert any(f"GoTo {NAME} started." in m for m in logged), logged[-5:]
    assert scene.selected() == NAME  # the card's refresh keeps it too


def test_the_moon_card_says_its_phase(server_factory: ServerFactory, browser: WebDriver) -> None:
    scene = Scene(server_factory, browser, "desktop", "Vega", latitude=SYDNEY)
    api = scene.client.session.get(f"{scene.client.api}/object", params={"id": "body:Moon"}, timeout=TIMEOUT).json()
    now = datetime.fromisoformat(scene.client.status()["time"]["utc"].replace("Z", "+00:00"))
    moon = ephem.Moon(ephem.Date(now.astimezone(timezone.utc).replace(tzinfo=None)))
    assert api["phase"]["lit_percent"] == pytest.approx(float(moon.moon_phase) * 100, abs=1.0)
    scene.find("Moon", False)
    WebDriverWait(scene.driver, TIMEOUT).until(lambda d: scene.selected() == "Moon")
    WebDriverWait(scene.driver, TIMEOUT).until(lambda d: "% lit" in shown(d, "sel-facts"))
    said = shown(scene.driver, "sel-facts")
    assert f"{api['phase']['words']}, {api['phase']['lit_percent']:.0f}% lit" in said, said
    assert api["phase"]["words"] in ("new moon", "full moon", "first quarter", "last quarter", "waxing crescent",
                                     "waning crescent", "waxing gibbous", "waning gibbous")
