"""The Satellites card in real Chromium (issue 41): a pasted TLE is kept and listed with its passes in the
site's time, an old set is marked, and a bad paste says why. Judged against the server's own answers
(``/setup/api/telescope/0/satellites``)."""

from __future__ import annotations

from pathlib import Path

from selenium.webdriver.common.by import By
from selenium.webdriver.remote.webdriver import WebDriver
from selenium.webdriver.support.ui import WebDriverWait

from tests.conftest import ServerFactory
from tests.web.test_setup_api import Client

TIMEOUT = 15
ISS_TEXT = (Path(__file__).parents[1] / "support" / "tle" / "iss-2018-05-15.tle").read_text(encoding="utf-8")


def _paste(driver: WebDriver, text: str) -> None:
    area = driver.find_element(By.ID, "tle-text")
    driver.execute_script("arguments[0].scrollIntoView({block: 'center'})", area)
    area.clear()
    driver.execute_script("arguments[0].value = arguments[1]", area, text)
    driver.find_element(By.CSS_SELECTOR, "#form-tle button[type=submit]").click()


def test_a_pasted_tle_is_kept_and_its_passes_listed(server_factory: ServerFactory, browser: WebDriver) -> None:
    server = server_factory()
    browser.set_window_size(1280, 900)
    browser.get(f"http://127.0.0.1:{server.port}/setup")
    WebDriverWait(browser, TIMEOUT).until(lambda d: d.find_element(By.ID, "link-pill").text.startswith("mount:"))
    _paste(browser, ISS_TEXT.replace("51.6402", "51.6403"))
    WebDriverWait(browser, TIMEOUT).until(lambda d: "checksum" in d.find_element(By.ID, "messages").text)
    _paste(browser, ISS_TEXT)
    rows = WebDriverWait(browser, TIMEOUT).until(
        lambda d: d.find_elements(By.CSS_SELECTOR, "#sat-passes tr") or None)
    truth = Client(f"http://127.0.0.1:{server.port}").session.get(
        f"http://127.0.0.1:{server.port}/setup/api/telescope/0/satellites", timeout=10).json()
    (sat,) = truth["satellites"]
    assert len(rows) == max(1, len(sat["passes"]))
    first = rows[0].find_elements(By.TAG_NAME, "td")
    assert first[0].text == "ISS (ZARYA) \u26a0"  # years old: marked, the reason in its title
    assert "days old" in first[0].get_attribute("title")
    if sat["passes"]:
        rise = sat["passes"][0]["rise"]["site"]
        assert first[1].text.startswith(rise[:10] + " " + rise[11:19])
        assert first[4].find_element(By.TAG_NAME, "button").text == "Follow"
    assert browser.find_element(By.ID, "sat-zone").text.startswith("Times in the site's zone:")
    assert browser.find_element(By.ID, "tle-text").get_attribute("value") == ""
