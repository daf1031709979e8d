"""The meridian line tells what the mount will do (issue 43 point 5), in real Chromium at 390x844 (night mode,
a Sydney site) and 1280x900 (Greenwich).

With factory settings a ZWO mount stops tracking 1° past the meridian and never flips by itself (ZWO's ``:STa``
text, docs/meridian.md E1): the page says so, and says what N.I.N.A.'s Meridian Flip settings must be for its
flip to come first. Each setting is changed on the page's own form, and the line follows the mount's setting;
the emulator's own stop rule is the same one (``sky.tracking_stop_deg``)."""

from __future__ import annotations

import pytest
from selenium.webdriver.common.by import By
from selenium.webdriver.remote.webdriver import WebDriver
from selenium.webdriver.support.ui import WebDriverWait

from alpaca_zwo import sky
from tests.browser.test_page_handset import TIMEOUT, Scene, tap
from tests.conftest import ServerFactory


@pytest.mark.parametrize(("limit", "track_past", "stop"), [
    (0.0, False, 1.0), (5.0, False, 1.0), (5.0, True, 5.0), (0.0, True, 1.0), (-3.0, False, -3.0), (-3.0, True, -3.0),
])
def test_where_tracking_stops(limit: float, track_past: bool, stop: float) -> None:
    assert sky.tracking_stop_deg(limit, track_past) == stop


def _save(scene: Scene, track_past: bool, limit: int) -> None:
    driver = scene.driver
    box = driver.find_element(By.ID, "mer-track")
    if box.is_selected() != track_past:
        tap(driver, box)
    field = driver.find_element(By.ID, "mer-limit")
    field.clear()
    field.send_keys(str(limit))
    tap(driver, driver.find_element(By.CSS_SELECTOR, "#form-meridian button[type='submit']"))
    WebDriverWait(driver, TIMEOUT).until(lambda d: "Meridian settings saved" in d.find_element(By.ID, "messages").text)


def _said(driver: WebDriver) -> tuple[str, str]:
    return (driver.find_element(By.ID, "meridian").get_attribute("textContent") or "",
            driver.find_element(By.ID, "mer-nina").get_attribute("textContent") or "")


@pytest.mark.parametrize(("size", "latitude"), [("phone", -33.8688), ("desktop", 51.4769)])
def test_the_meridian_line_and_the_advice_for_nina_follow_the_mounts_setting(server_factory: ServerFactory,
                                                                             browser: WebDriver, size: str,
                                                                             latitude: float) -> None:
    scene = Scene(server_factory, browser, size, "Vega" if latitude > 0 else "Canopus", latitude=latitude)
    driver = scene.driver
    WebDriverWait(driver, TIMEOUT).until(lambda d: "tracking stops" in _said(d)[0])
    line, advice = _said(driver)
    assert line.startswith("tracking stops 1° past the meridian") and "does not flip by itself" in line, line
    assert "flips at the meridian" not in line
    assert "4 min after the meridian" in advice and "Max minutes after meridian to 3 or less" in advice, advice
    assert "Track past the meridian with a limit of 3° (12 min)" in advice, advice

    _save(scene, True, 5)
    WebDriverWait(driver, TIMEOUT).until(lambda d: _said(d)[0].startswith("tracking stops 5° past the meridian"))
    assert scene.client.status()["meridian"]["stop_deg"] == 5
    line, advice = _said(driver)
    assert "20 min after the meridian" in advice and "to 19 or less" in advice and "To keep" not in advice, advice

    _save(scene, False, -3)
    WebDriverWait(driver, TIMEOUT).until(lambda d: _said(d)[0].startswith("tracking stops 3° before the meridian"))
    line, advice = _said(driver)
    assert "12 min before the meridian" in advice and "Pause before meridian to 13 min or more" in advice, advice
    driver.save_screenshot(f"/tmp/alpaca-zwo-meridian-{size}.png")
