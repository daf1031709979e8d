"""The first-run site form where the prompt is (issue 43 point 4), in real Chromium at 390x844 and 1280x900,
over plain http as a phone reaches a Pi (a host name mapped to 127.0.0.1: not a secure context).

The line at the top asks where the telescope is and holds latitude, longitude and elevation itself; the
location button is not offered where the browser cannot answer; saving says whether the site reached the
mount, which the Alpaca API then reads."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import pytest
from selenium.webdriver.common.by import By
from selenium.webdriver.support.ui import WebDriverWait

from alpaca_zwo.config.settings import SiteSettings
from tests.browser.test_page_first_contact import LOCAL_NAME  # this machine's <hostname>.local: allowed, not secure
from tests.browser.test_page_handset import SIZES, TIMEOUT, tap
from tests.conftest import ServerFactory, make_settings
from tests.web.test_setup_api import Client


@pytest.mark.parametrize(("size", "connected"), [("phone", False), ("desktop", True)])
def test_the_site_is_asked_for_where_the_prompt_is(browser_factory: Callable[..., Any], server_factory: ServerFactory,
                                                   size: str, connected: bool) -> None:
    server = server_factory(make_settings(site=SiteSettings()))  # the factory site: Greenwich
    client = Client(f"http://127.0.0.1:{server.port}")
    if connected:
        client.command("connected", Connected="true")
    driver = browser_factory(f"--host-resolver-rules=MAP {LOCAL_NAME} 127.0.0.1")
    driver.set_window_size(*SIZES[size])
    driver.get(f"http://{LOCAL_NAME}:{server.port}/setup")
    WebDriverWait(driver, TIMEOUT).until(lambda d: d.find_element(By.ID, "form-first-site").is_displayed())
    assert driver.execute_script("return window.isSecureContext") is False
    assert "where is the telescope?" in driver.find_element(By.ID, "site-line").text
    assert not driver.find_element(By.ID, "btn-device-site").is_displayed()
    assert "longitude here" in driver.find_element(By.ID, "field-note").text
    form = driver.find_element(By.ID, "form-first-site").rect
    assert form["y"] + form["height"] <= driver.execute_script("return window.innerHeight"), form  # on the first screen

    for field_id, value in (("fs-lat", "-33.8688"), ("fs-lon", "151.2093")):
        field = driver.find_element(By.ID, field_id)
        tap(driver, field)
        field.send_keys(value)
    tap(driver, driver.find_element(By.CSS_SELECTOR, "#form-first-site button[type='submit']"))
    assert client.value("sitelatitude") == 51.4769  # the browser asks for the elevation: nothing was sent
    elevation = driver.find_element(By.ID, "fs-elev")
    assert driver.execute_script("return arguments[0].validity.valueMissing", elevation)
    elevation.send_keys("40")
    tap(driver, driver.find_element(By.CSS_SELECTOR, "#form-first-site button[type='submit']"))
    said = "Site saved and sent to the mount." if connected else "Site saved; the mount gets it when it is connected."
    WebDriverWait(driver, TIMEOUT).until(lambda d: said in d.find_element(By.ID, "messages").text)
    site = client.settings()["site"]
    assert (site["latitude"], site["longitude"], site["elevation"]) == (-33.8688, 151.2093, 40.0)
    if connected:
        assert client.value("sitelatitude") == -33.8688 and client.value("siteelevation") == 40.0
    WebDriverWait(driver, TIMEOUT).until(lambda d: not d.find_element(By.ID, "field-line").is_displayed())
    driver.save_screenshot(f"/tmp/alpaca-zwo-first-site-{size}.png")
