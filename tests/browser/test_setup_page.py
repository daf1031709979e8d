"""The setup page in a real browser (headless Chromium) against a real server on the emulator.

Every wait is an explicit WebDriverWait on a condition with a deadline; nothing sleeps.
"""

from __future__ import annotations

import socket
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from selenium.webdriver.common.action_chains import ActionChains
from selenium.webdriver.common.by import By
from selenium.webdriver.remote.webdriver import WebDriver
from selenium.webdriver.support.ui import WebDriverWait

from alpaca_zwo.config.file import load_settings
from alpaca_zwo.config.settings import StellariumSettings
from alpaca_zwo.server import AlpacaZwoServer
from tests.conftest import make_settings
from tests.support import AlpacaClient

TIMEOUT = 10
DASH = "\u2013"


def text(driver: WebDriver, element_id: str) -> str:
    return driver.find_element(By.ID, element_id).text


def console_errors(driver: WebDriver) -> list[dict[str, Any]]:
    return [e for e in driver.get_log("browser") if e["level"] in ("SEVERE", "ERROR")]


def open_page(driver: WebDriver, port: int, path: str = "/setup") -> None:
    driver.get(f"http://127.0.0.1:{port}{path}")
    # The first status poll has been rendered once the link pill names the mount's link state.
    WebDriverWait(driver, 15).until(lambda d: text(d, "link-pill").startswith("mount:"))


def start_goto(alpaca: AlpacaClient, ha_hours: float, dec: float) -> float:
    """Start a GOTO to an hour angle (east is negative) and declination; return the target RA."""
    alpaca.command("tracking", Tracking="true")
    ra = (alpaca.value("siderealtime") - ha_hours) % 24
    alpaca.command("slewtocoordinatesasync", RightAscension=ra, Declination=dec)
    return ra


@pytest.fixture
def server(server_factory: Callable[..., AlpacaZwoServer]) -> AlpacaZwoServer:
    return server_factory()


@pytest.fixture
def alpaca(server: AlpacaZwoServer) -> AlpacaClient:
    client = AlpacaClient(server.port, timeout=TIMEOUT, call_timeout=TIMEOUT)
    client.command("connected", Connected="true")
    return client


def test_page_loads_without_console_errors(browser: WebDriver, server: AlpacaZwoServer) -> None:
    for path in ("/setup", "/setup/v1/telescope/0/setup"):
        open_page(browser, server.port, path)
        assert browser.title == "alpaca-zwo setup"
        assert text(browser, "device-name").endswith("ZWO AM5")
        assert browser.find_elements(By.CSS_SELECTOR, "#sky circle"), "the sky plot was not drawn"
    # Connect from the page itself, exercise the panels and night mode, then read the console.
    browser.find_element(By.ID, "btn-connect").click()
    WebDriverWait(browser, 15).until(lambda d: text(d, "ra") != DASH)
    WebDriverWait(browser, 10).until(lambda d: d.find_element(By.ID, "btn-disconnect").is_displayed())
    for panel in ("#trace-panel summary", "#log-panel summary"):  # scrolled clear of the STOP bar at the bottom
        summary = browser.find_element(By.CSS_SELECTOR, panel)
        browser.execute_script("arguments[0].scrollIntoView({block: 'center'})", summary)
        summary.click()
    WebDriverWait(browser, 10).until(lambda d: d.find_elements(By.CSS_SELECTOR, "#trace tr"))
    browser.find_element(By.ID, "btn-night").click()
    assert "night" in browser.find_element(By.TAG_NAME, "html").get_attribute("class")
    browser.find_element(By.ID, "btn-night").click()
    WebDriverWait(browser, 10).until(lambda d: not d.find_element(By.ID, "mer-limit").get_attribute("disabled"))
    errors = console_errors(browser)
    assert errors == [], errors
    browser.save_screenshot("/tmp/alpaca-zwo-setup-page.png")


def test_status_updates_live_while_the_mount_slews(browser: WebDriver, server: AlpacaZwoServer,
                                                   alpaca: AlpacaClient) -> None:
    open_page(browser, server.port)
    WebDriverWait(browser, 15).until(lambda d: text(d, "dec") != DASH)
    start_goto(alpaca, ha_hours=-2.0, dec=20.0)
    WebDriverWait(browser, 10).until(lambda d: text(d, "slewing").startswith("yes"))

    seen: list[tuple[str, str]] = []

    def position_changed_three_times(d: WebDriver) -> bool:
        pair = (text(d, "ra"), text(d, "dec"))
        if not seen or seen[-1] != pair:
            seen.append(pair)
        return len(seen) >= 4

    WebDriverWait(browser, 30, poll_frequency=0.1).until(position_changed_three_times)
    target = browser.find_elements(By.CSS_SELECTOR, "#sky .sky-target:not(.hidden)")
    assert target, "the target is not drawn while slewing"
    WebDriverWait(browser, 90).until(lambda d: text(d, "slewing") == "no")
    WebDriverWait(browser, 10).until(lambda d: text(d, "dec").startswith("+20\u00b0 00\u2032"))
    assert text(browser, "tracking") == "on, sidereal"
    assert text(browser, "pier").startswith("west")
    assert console_errors(browser) == []


def test_changed_setting_persists_across_a_restart(browser: WebDriver, tmp_path: Path,
                                                   server_factory: Callable[..., AlpacaZwoServer]) -> None:
    first = server_factory(make_settings(), config_name="browser.toml")
    open_page(browser, first.port)
    WebDriverWait(browser, 10).until(lambda d: d.find_element(By.ID, "site-lat").get_attribute("value") != "")
    for element_id, value in (("site-lat", "-31.2733"), ("site-lon", "149.0617"), ("site-elev", "1165")):
        field = browser.find_element(By.ID, element_id)
        field.clear()
        field.send_keys(value)
    browser.find_element(By.CSS_SELECTOR, "#form-site button[type=submit]").click()
    WebDriverWait(browser, 10).until(lambda d: "Site saved" in text(d, "messages"))
    assert AlpacaClient(first.port, timeout=TIMEOUT, call_timeout=TIMEOUT).value("sitelatitude") == -31.2733
    first.stop()

    second = server_factory(load_settings(tmp_path / "browser.toml"), config_name="browser.toml")
    open_page(browser, second.port)
    WebDriverWait(browser, 10).until(lambda d: d.find_element(By.ID, "site-lat").get_attribute("value") == "-31.2733")
    assert browser.find_element(By.ID, "site-lon").get_attribute("value") == "149.0617"
    alpaca = AlpacaClient(second.port, timeout=TIMEOUT, call_timeout=TIMEOUT)
    assert alpaca.value("sitelatitude") == -31.2733
    assert alpaca.value("sitelongitude") == 149.0617
    assert alpaca.value("siteelevation") == 1165
    # The southern sky: the chart faces north (the equator), so the south celestial pole is up the chart and
    # south's letter above north's (docs/objects.md, "The chart's orientation").
    WebDriverWait(browser, 10).until(lambda d: "facing north" in text(d, "sky-orientation"))
    pole = browser.find_element(By.ID, "sky-pole").get_attribute("transform") or ""
    assert pole.startswith("translate(") and float(pole.split()[1].rstrip(")")) < 0
    letters = {t.text: t.location["y"] for t in browser.find_elements(By.CSS_SELECTOR, "#sky > text.sky-label")}
    assert letters["S"] < letters["N"], letters


def test_stop_button_stops_a_slew(browser: WebDriver, server: AlpacaZwoServer, alpaca: AlpacaClient) -> None:
    open_page(browser, server.port)
    start_goto(alpaca, ha_hours=3.0, dec=-10.0)
    WebDriverWait(browser, 10).until(lambda d: text(d, "slewing").startswith("yes"))
    browser.find_element(By.ID, "btn-stop").click()
    WebDriverWait(browser, 10).until(lambda d: not alpaca.value("slewing"))
    WebDriverWait(browser, 10).until(lambda d: text(d, "slewing") == "no")
    # After braking the mount stays where it stopped, far from the target.
    readings: list[float] = []

    def at_rest(_: WebDriver) -> bool:
        readings.append(alpaca.value("declination"))
        return len(readings) >= 5 and max(readings[-5:]) - min(readings[-5:]) < 5 / 3600

    WebDriverWait(browser, 20, poll_frequency=0.2).until(at_rest)
    assert readings[-1] > 0
    WebDriverWait(browser, 10).until(lambda d: text(d, "arrival").startswith("Stopped"))


def test_jog_button_moves_while_pressed(browser: WebDriver, server: AlpacaZwoServer, alpaca: AlpacaClient) -> None:
    open_page(browser, server.port)
    WebDriverWait(browser, 15).until(lambda d: d.find_element(By.ID, "jog-s").is_enabled())
    start_dec = alpaca.value("declination")
    button = browser.find_element(By.ID, "jog-s")
    ActionChains(browser).click_and_hold(button).perform()
    WebDriverWait(browser, 10).until(lambda d: alpaca.value("slewing"))
    WebDriverWait(browser, 20).until(lambda d: alpaca.value("declination") < start_dec - 0.05)
    ActionChains(browser).release(button).perform()
    WebDriverWait(browser, 10).until(lambda d: not alpaca.value("slewing"))
    WebDriverWait(browser, 10).until(lambda d: text(d, "slewing") == "no")
    assert console_errors(browser) == []


def test_bridges_panel_shows_running_bridges(browser: WebDriver,
                                             server_factory: Callable[..., AlpacaZwoServer]) -> None:
    bare = server_factory()
    open_page(browser, bare.port)
    WebDriverWait(browser, 10).until(lambda d: text(d, "bridges").startswith("none running"))
    assert text(browser, "clients").startswith("setup page (127.0.0.1)")  # the page itself, as a client

    settings = make_settings(stellarium=StellariumSettings(enabled=True, host="127.0.0.1", port=0))
    server = server_factory(settings, config_name="bridges.toml")
    port = server.stellarium.port
    with socket.create_connection(("127.0.0.1", port), timeout=TIMEOUT) as program:
        open_page(browser, server.port)
        row = f"stellarium yes {port} 127.0.0.1"
        WebDriverWait(browser, 10).until(lambda d: text(d, "bridges").startswith(row))
        program.close()
    WebDriverWait(browser, 10).until(lambda d: text(d, "bridges").startswith(f"stellarium yes {port} none"))
    assert console_errors(browser) == []


def test_observatory_form_sets_the_monitor_and_the_page_shows_its_answer(
        browser: WebDriver, server: AlpacaZwoServer, alpaca: AlpacaClient, tmp_path: Path) -> None:
    """The Observatory form takes a real SafetyMonitor's URL (alpaca-simulators); the Status list and the form
    show its answer; unsafe, the page's Unpark is refused with the monitor's reason; no console errors."""
    from tests.support.observatory import AlpacaSimulators

    with AlpacaSimulators(tmp_path) as sims:
        open_page(browser, server.port)
        WebDriverWait(browser, 10).until(lambda d: d.find_element(By.ID, "o-poll").get_attribute("value") != "")
        assert text(browser, "safety") == "off (no monitor)"
        monitor = browser.find_element(By.ID, "o-monitor")
        monitor.clear()
        monitor.send_keys(sims.monitor_url)
        poll = browser.find_element(By.ID, "o-poll")
        poll.clear()
        poll.send_keys("0.5")
        browser.find_element(By.CSS_SELECTOR, "#form-observatory button[type=submit]").click()
        WebDriverWait(browser, 10).until(lambda d: "Observatory settings saved" in text(d, "messages"))
        assert server.settings.safety.monitor == sims.monitor_url and server.settings.safety.poll_s == 0.5
        WebDriverWait(browser, 10).until(lambda d: text(d, "safety") == "safe")
        assert "IsSafe=true" in text(browser, "o-state")
        sims.set_safe(False)
        WebDriverWait(browser, 10).until(lambda d: text(d, "safety").startswith("UNSAFE"))
        assert "IsSafe=false" in text(browser, "o-state")
        WebDriverWait(browser, 60).until(lambda d: text(d, "park") == "parked")  # on_unsafe = "park"
        browser.find_element(By.ID, "btn-unpark").click()
        beside = ("return (document.querySelector('#btn-unpark').closest('.row').nextElementSibling || {})"
                  ".innerText || ''")
        WebDriverWait(browser, 10).until(lambda d: "safety monitor" in d.execute_script(beside))  # beside Unpark
        assert alpaca.value("atpark") is True
        refused = "/action/unpark - Failed to load resource: the server responded with a status of 409"
        assert [e for e in console_errors(browser) if refused not in e["message"]] == []  # the refusal only
