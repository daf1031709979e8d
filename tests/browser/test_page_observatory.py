"""The observatory form forgives a missing scheme and tests a device once before it is saved (issue 43 point 9),
against real third-party Alpaca devices (alpaca-simulators' SafetyMonitor and Dome), in real Chromium at
390x844 (night mode) and 1280x900."""

from __future__ import annotations

from pathlib import Path

import pytest
from selenium.webdriver.common.by import By
from selenium.webdriver.remote.webdriver import WebDriver
from selenium.webdriver.support.ui import WebDriverWait

from tests.browser.test_page_handset import TIMEOUT, Scene, tap
from tests.conftest import ServerFactory


def _type(driver: WebDriver, field_id: str, value: str) -> None:
    field = driver.find_element(By.ID, field_id)
    tap(driver, field)
    field.clear()
    field.send_keys(value)


def _test_line(driver: WebDriver) -> str:
    box = driver.find_element(By.ID, "o-test")
    return box.text if box.is_displayed() else ""


@pytest.mark.parametrize("size", ["phone", "desktop"])
def test_a_url_without_its_scheme_is_tested_and_saved(server_factory: ServerFactory, browser: WebDriver, size: str,
                                                      tmp_path: Path) -> None:
    from tests.support.observatory import AlpacaSimulators

    scene = Scene(server_factory, browser, size, "Vega")
    driver, client = scene.driver, scene.client
    with AlpacaSimulators(tmp_path) as sims:
        bare = sims.monitor_url.removeprefix("http://")  # as the field's label writes it
        _type(driver, "o-monitor", bare)
        tap(driver, driver.find_element(By.ID, "btn-test-monitor"))
        WebDriverWait(driver, TIMEOUT).until(lambda d: "answered IsSafe=" in _test_line(d))
        said = _test_line(driver)
        assert said.startswith(f"The monitor at {sims.monitor_url} answered IsSafe=true: motion would be allowed"), said
        assert client.status()["safety"]["state"] == "off"  # a test changes nothing
        sims.set_safe(False)
        tap(driver, driver.find_element(By.ID, "btn-test-monitor"))
        WebDriverWait(driver, TIMEOUT).until(lambda d: "IsSafe=false: motion would be refused." in _test_line(d))

        # A roof nobody answers for: said in words beside the buttons, nothing saved.
        _type(driver, "o-roof", "127.0.0.1:9/api/v1/dome/0")
        tap(driver, driver.find_element(By.ID, "btn-test-roof"))
        WebDriverWait(driver, 30).until(lambda d: "did not answer" in _test_line(d))
        assert _test_line(driver).startswith("The roof at http://127.0.0.1:9/api/v1/dome/0 did not answer: ")

        _type(driver, "o-roof", "")
        sims.set_safe(True)
        tap(driver, driver.find_element(By.CSS_SELECTOR, "#form-observatory button[type='submit']"))
        WebDriverWait(driver, TIMEOUT).until(
            lambda d: "Observatory settings saved" in d.find_element(By.ID, "messages").text)
        assert client.settings()["safety"]["monitor"] == sims.monitor_url  # stored with its scheme
        WebDriverWait(driver, TIMEOUT).until(lambda d: client.status()["safety"]["state"] == "safe")
        assert driver.find_element(By.ID, "o-monitor").get_attribute("value") == sims.monitor_url
        driver.save_screenshot(f"/tmp/alpaca-zwo-observatory-{size}.png")

