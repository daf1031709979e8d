"""The page's pointing model card in real Chromium (issue 40 item 2): syncs made over Alpaca appear as
markers on the sky chart and as rows with their residuals, the terms and RMS are shown, the switch and
Clear change the server's model (judged through the Alpaca Action), and nothing logs a console error.
Every wait is an explicit WebDriverWait; nothing sleeps."""

from __future__ import annotations

import json
from collections.abc import Callable
from typing import Any

from selenium.webdriver.common.by import By
from selenium.webdriver.remote.webdriver import WebDriver
from selenium.webdriver.support.ui import WebDriverWait

from alpaca_zwo.config.settings import EmulatorSettings
from alpaca_zwo.server import AlpacaZwoServer
from tests.browser.test_setup_page import console_errors, open_page, start_goto
from tests.conftest import make_settings
from tests.support import AlpacaClient, wait_until

TIMEOUT = 20


def model(alpaca: AlpacaClient) -> dict[str, Any]:
    call = alpaca.put("action", Action="zwo:PointingModel", Parameters="")
    assert call.ok, call.describe()
    reply = json.loads(call.value)
    assert isinstance(reply, dict)
    return reply


def test_the_card_shows_the_syncs_and_switches_and_clears_the_model(
        browser: WebDriver, server_factory: Callable[..., AlpacaZwoServer]) -> None:
    server = server_factory(make_settings(emulator=EmulatorSettings(speed=8.0, baud=0,
                                                                    pointing_errors="IH=20,ID=-8,MA=12,ME=-9")))
    alpaca = AlpacaClient(server.port, timeout=TIMEOUT, call_timeout=TIMEOUT)
    alpaca.command("connected", Connected="true")
    emulator = server.emulators[0]
    assert emulator is not None
    for ha, dec in ((-2.5, 20.0), (-1.2, 50.0), (1.5, 35.0), (3.0, 10.0)):
        start_goto(alpaca, ha, dec)
        wait_until(lambda: alpaca.value("slewing") is False, 60, "the slew to end")
        ra, dec_true, _, _ = emulator.model.sky()  # a plate solve's answer
        alpaca.command("synctocoordinates", RightAscension=ra, Declination=dec_true)
    assert len(model(alpaca)["points"]) == 4  # the last one within 1″ of the model too: a point all the same
    open_page(browser, server.port)
    wait = WebDriverWait(browser, TIMEOUT)
    wait.until(lambda d: len(d.find_elements(By.CSS_SELECTOR, "#sky-pointing circle")) == 4)
    assert len(browser.find_elements(By.CSS_SELECTOR, "#pm-points tr")) == 4
    terms = [row.text.split()[0] for row in browser.find_elements(By.CSS_SELECTOR, "#pm-terms-body tr")]
    assert terms[:4] == ["IH", "ID", "MA", "ME"]
    assert "4 points, RMS" in browser.find_element(By.ID, "pm-summary").text
    switch = browser.find_element(By.ID, "pm-enabled")
    browser.execute_script("arguments[0].scrollIntoView({block: 'center'})", switch)
    assert switch.is_selected()
    switch.click()
    wait_until(lambda: model(alpaca)["enabled"] is False, TIMEOUT, "the page to switch the model off")
    browser.find_element(By.ID, "pm-clear").click()
    browser.switch_to.alert.accept()
    wait_until(lambda: model(alpaca)["points"] == [], TIMEOUT, "the page to clear the model")
    wait.until(lambda d: not d.find_elements(By.CSS_SELECTOR, "#sky-pointing circle"))
    assert "No points yet" in browser.find_element(By.ID, "pm-summary").text
    errors = console_errors(browser)
    assert errors == [], errors
