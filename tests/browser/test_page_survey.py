"""The Survey button in real Chromium (issue 39 item 5): refused in words while the mount moves, then the
verdict of the built-in emulator's preset, and the report offered for download with the same text."""

from __future__ import annotations

import requests
from selenium.webdriver.common.by import By
from selenium.webdriver.remote.webdriver import WebDriver
from selenium.webdriver.support.ui import WebDriverWait

from alpaca_zwo.config.settings import EmulatorSettings
from alpaca_zwo.server import Overrides
from tests.conftest import ServerFactory, make_settings
from tests.support import wait_until
from tests.web.test_setup_api import Client

TIMEOUT = 20


def _states(driver: WebDriver) -> dict[str, tuple[str, str]]:
    """The verdict list as shown: switch -> (state, line)."""
    items = driver.find_elements(By.CSS_SELECTOR, "#survey-verdict li")
    return {str(i.get_attribute("data-switch")): (str(i.get_attribute("data-state")), i.text) for i in items}


def test_survey_button_refuses_while_moving_then_shows_the_verdict_and_the_report(
        server_factory: ServerFactory, browser: WebDriver) -> None:
    server = server_factory(make_settings(emulator=EmulatorSettings(speed=1.0, baud=0)),
                            Overrides(emulator_preset="am5-x2"))
    client = Client(f"http://127.0.0.1:{server.port}")
    client.command("connected", Connected="true")
    wait_until(lambda: client.status()["position"] is not None, what="a first position")
    browser.get(f"{client.base}/setup")
    WebDriverWait(browser, TIMEOUT).until(lambda d: d.find_element(By.ID, "link-pill").text.startswith("mount:"))
    run = browser.find_element(By.ID, "survey-run")
    download = browser.find_element(By.ID, "survey-download")
    assert not download.is_displayed()

    client.action("move", {"axis": 0, "rate": 1.0})
    try:
        browser.execute_script("arguments[0].scrollIntoView()", run)
        run.click()
        beside = "return (document.getElementById('survey-run').nextElementSibling || {}).innerText || ''"
        WebDriverWait(browser, TIMEOUT).until(lambda d: d.execute_script(beside).startswith("The survey did not run:"))
        assert "survey not run: the mount is" in browser.execute_script(beside)  # beside the button, once
        assert browser.find_element(By.ID, "survey-status").text == ""
        assert not download.is_displayed() and not _states(browser)
    finally:
        client.action("abort")
    wait_until(lambda: not client.value("slewing"), what="the mount at rest")

    run.click()
    WebDriverWait(browser, TIMEOUT).until(lambda d: d.find_element(By.ID, "survey-status").text.startswith("Surveyed"))
    states = _states(browser)
    assert states["gps_reply"] == ("settled", "gps_reply = 'empty' (from :Gps#)")
    assert states["model"][0] == "settled" and states["hp_reply"][0] == "open"
    assert states["gh_reply"][0] == "narrowed" and "'homed' or 'zero'" in states["gh_reply"][1]
    assert download.is_displayed() and str(download.get_attribute("href")).endswith("/telescope/0/survey.txt")
    text = requests.get(str(download.get_attribute("href")), timeout=TIMEOUT).text
    assert "connection: the built-in emulator, preset am5-x2" in text and "gps_reply = 'empty'" in text
