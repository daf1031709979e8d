"""One message place, and STOP honest through braking (issue 43 points 1 and 2), in real Chromium at
390x844 (night mode, as at the telescope) and 1280x900.

A first night at 51.5° N with the mount left parked: GoTos to two bright stars are refused one after the
other (a star that is down gets no GoTo to refuse: tests/browser/test_page_goto_verdict.py). Each refusal is
shown beside the GoTo that caused it, the newest replacing the one before, never over GoTo or STOP; both are in the
log (the Log panel, times with their zone), and choosing another object clears them. STOP is judged against
the mount: on a real-time emulator clock the mount brakes for about two seconds after it has the stop, and
the page may say where it came to rest only after Alpaca's Slewing has turned false.
"""

from __future__ import annotations

import re
import time
from typing import Any

import pytest
from selenium.webdriver.common.by import By
from selenium.webdriver.remote.webdriver import WebDriver
from selenium.webdriver.support.ui import WebDriverWait

from alpaca_zwo.catalogue import objects
from alpaca_zwo.config.settings import EmulatorSettings, SiteSettings
from tests.browser.test_page_handset import SIZES, TIMEOUT, Scene, button, refusal, shown, tap
from tests.conftest import ServerFactory, make_settings
from tests.support import wait_until
from tests.web.test_setup_api import Client
from tests.web.test_setup_goto import LATITUDE, _longitude_putting

#: Reads what covers the centre of an element: its own id when nothing does.
_HIT = ("const r = document.getElementById(arguments[0]).getBoundingClientRect();"
        " const e = document.elementFromPoint(r.left + r.width / 2, r.top + r.height / 2);"
        " return e ? (e.closest('#' + arguments[0]) ? arguments[0] : e.id + '.' + e.className) : null;")


def _inside_the_bar(driver: WebDriver) -> bool:
    """Every message box lies within STOP's bar, which the page is padded for."""
    return bool(driver.execute_script(
        "const bar = document.querySelector('.stop-bar').getBoundingClientRect();"
        " return [...document.querySelectorAll('#messages .msg')].every((m) => { const r = m.getBoundingClientRect();"
        " return r.top >= bar.top && r.bottom <= bar.bottom && r.left >= bar.left && r.right <= bar.right; });"))


def _log_messages(client: Client) -> list[str]:
    entries = client.session.get(f"{client.base}/setup/api/log", timeout=TIMEOUT).json()["entries"]
    return [str(e["message"]) for e in entries]


def _refuse(scene: Scene, star: str) -> None:
    scene.find(star, False)
    WebDriverWait(scene.driver, TIMEOUT).until(lambda d: scene.selected() == star)
    assert refusal(scene.driver) == ""  # a new selection starts clean
    tap(scene.driver, button(scene.driver, "GoTo"))
    WebDriverWait(scene.driver, TIMEOUT).until(lambda d: f"GoTo {star} refused: " in refusal(d))


@pytest.mark.parametrize("size", ["phone", "desktop"])
def test_refusals_beside_goto_newest_only_in_the_log_cleared_by_a_new_choice(server_factory: ServerFactory,
                                                                             browser: WebDriver, size: str) -> None:
    scene = Scene(server_factory, browser, size, "Vega")
    driver, client = scene.driver, scene.client
    stop = driver.execute_script("return JSON.stringify(document.getElementById('btn-stop').getBoundingClientRect())")
    client.action("park")
    wait_until(lambda: client.status()["at_park"], 60, "the mount to park")
    for star in ("Vega", "Altair"):  # both up at 51.5° N: refused because the mount is parked
        _refuse(scene, star)
        boxes = driver.execute_script("return document.querySelectorAll('.refusal').length")
        assert boxes == 1, boxes  # the newest replaced the one before: nothing stacks
        assert driver.find_element(By.ID, "messages").text == ""
        for control in ("btn-goto", "btn-sync", "btn-stop"):  # the refusal covers none of them
            assert driver.execute_script(_HIT, control) == control, control
    said = refusal(driver)
    assert "Vega" not in said and "GoTo Altair refused: " in said and "unpark it first" in said, said
    if size == "phone":  # night mode: the refusal is red light only
        colour = driver.execute_script("return getComputedStyle(document.querySelector('.refusal')).color")
        red, green, blue = (int(v) for v in re.findall(r"\d+", colour)[:3])
        assert red > 0 and green == 0 and blue == 0, colour
    driver.save_screenshot(f"/tmp/alpaca-zwo-refusal-{size}.png")
    # Both refusals are the log's history, and the Log panel names the zone of its times.
    logged = _log_messages(client)
    assert any("GoTo Vega refused: " in m for m in logged) and any("GoTo Altair refused: " in m for m in logged)
    driver.execute_script("document.getElementById('log-panel').open = true;"
                          " document.getElementById('log-panel').dispatchEvent(new Event('toggle'))")
    WebDriverWait(driver, TIMEOUT).until(
        lambda d: re.search(r"^\d\d:\d\d:\d\d UTC WARNING .*GoTo Vega refused: ",
                            d.find_element(By.ID, "log").get_attribute("textContent") or "", re.M))

    # Another choice clears them; a GoTo that starts says so in the one message place, inside STOP's bar.
    client.action("unpark")
    wait_until(lambda: not client.status()["at_park"], TIMEOUT, "the mount to unpark")
    scene.find("Vega", False)
    WebDriverWait(driver, TIMEOUT).until(lambda d: scene.selected() == "Vega")
    assert driver.execute_script("return document.querySelectorAll('.refusal, #messages .msg').length") == 0
    tap(driver, button(driver, "GoTo"))
    WebDriverWait(driver, TIMEOUT).until(lambda d: "GoTo Vega started." in d.find_element(By.ID, "messages").text)
    assert _inside_the_bar(driver)
    assert driver.execute_script(
        "return JSON.stringify(document.getElementById('btn-stop').getBoundingClientRect())") == stop
    assert driver.execute_script(_HIT, "btn-stop") == "btn-stop"


@pytest.mark.parametrize("size", ["phone", "desktop"])
def test_a_form_refusal_is_beside_its_form_and_a_success_there_clears_it(server_factory: ServerFactory,
                                                                         browser: WebDriver, size: str) -> None:
    scene = Scene(server_factory, browser, size, "Vega")
    driver = scene.driver
    profile = driver.find_element(By.ID, "h-profile")
    tap(driver, profile)
    profile.clear()
    profile.send_keys("north 15")
    save = driver.find_element(By.CSS_SELECTOR, "#form-horizon button[type='submit']")
    tap(driver, save)
    beside = "#form-horizon + .refusal"
    WebDriverWait(driver, TIMEOUT).until(lambda d: "horizon line 1" in d.find_element(By.CSS_SELECTOR, beside).text)
    assert driver.execute_script(_HIT, "h-profile") == "h-profile"
    profile.clear()
    profile.send_keys("0 15")
    tap(driver, save)
    WebDriverWait(driver, TIMEOUT).until(lambda d: "Horizon saved." in d.find_element(By.ID, "messages").text)
    assert driver.find_elements(By.CSS_SELECTOR, beside) == []
    assert _inside_the_bar(driver)


def _record_the_motion_line(driver: WebDriver) -> None:
    """Every text the progress and arrival lines show, with the wall-clock time (ms) it appeared."""
    driver.execute_script(
        "window.lineSeen = [];"
        " const note = () => { for (const id of ['progress', 'arrival']) { const e = document.getElementById(id);"
        " const t = e.classList.contains('hidden') ? '' : e.textContent; const last = window.lineSeen.filter((x) =>"
        " x[1] === id).pop(); if (!last || last[2] !== t) window.lineSeen.push([Date.now(), id, t]); } };"
        " const watch = new MutationObserver(note);"
        " for (const id of ['progress', 'arrival']) watch.observe(document.getElementById(id),"
        " {attributes: true, childList: true, characterData: true, subtree: true});")


@pytest.mark.parametrize("size", ["phone", "desktop"])
def test_stop_says_stopping_until_the_mount_is_at_rest_then_where(server_factory: ServerFactory,
                                                                  browser: WebDriver, size: str) -> None:
    vega = objects.lookup("Vega")
    lon = _longitude_putting(vega, latitude=LATITUDE)
    server = server_factory(make_settings(site=SiteSettings(latitude=LATITUDE, longitude=lon, elevation=46.0),
                                          emulator=EmulatorSettings(speed=1.0, baud=0)))  # real-time braking
    client = Client(f"http://127.0.0.1:{server.port}")
    client.command("connected", Connected="true")
    wait_until(lambda: client.status()["position"] is not None, what="a first position")
    browser.set_window_size(*SIZES[size])
    browser.get(f"http://127.0.0.1:{server.port}/setup")
    WebDriverWait(browser, TIMEOUT).until(lambda d: d.find_element(By.ID, "link-pill").text.startswith("mount:"))
    r = client.post("/setup/api/telescope/0/goto", {"id": "Vega"})
    assert r.status_code == 200, r.text
    WebDriverWait(browser, TIMEOUT).until(lambda d: " left" in shown(d, "progress"))
    emulator = server.emulators[0]
    assert emulator is not None
    # A fast slew (3°/s and more), so its braking lasts a second or more at 3°/s² on a real-time clock.
    wait_until(lambda: max(abs(v) for v in emulator.model.snapshot()["velocity_deg_s"]) >= 3.0, TIMEOUT,
               "the slew at speed")
    _record_the_motion_line(browser)
    tap(browser, browser.find_element(By.ID, "btn-stop"))
    pressed = time.time() * 1000
    last_slewing = pressed
    while True:  # the last instant Alpaca still read Slewing true: the request was sent no earlier
        sent = time.time() * 1000
        if not client.value("slewing"):
            break
        last_slewing = sent
        assert sent - pressed < 15000, "the mount never came to rest"
    assert last_slewing - pressed > 500, "the mount did not brake long enough to tell honest from not"
    WebDriverWait(browser, TIMEOUT).until(lambda d: shown(d, "arrival").startswith("Stopped before reaching"))
    seen: list[Any] = browser.execute_script("return window.lineSeen")
    lines = [(when, which, text) for when, which, text in seen if text]
    assert lines[0][1] == "progress" and lines[0][2].startswith("Stopping"), lines
    arrival = next((when, text) for when, which, text in lines if which == "arrival")
    assert arrival[0] >= last_slewing, (arrival, last_slewing, lines)  # said only once at rest
    said = arrival[1]
    assert ". At rest at RA " in said and "because" not in said, said
    assert "Stopped" not in browser.find_element(By.ID, "messages").text  # no "acknowledged" before the rest
    dec = re.search(r"Dec ([+\u2212])(\d+)\u00b0 (\d+)\u2032 (\d+)\u2033", said)
    assert dec is not None, said
    shown_dec = (-1 if dec.group(1) == "\u2212" else 1) * (int(dec.group(2)) + int(dec.group(3)) / 60 +
                                                         int(dec.group(4)) / 3600)
    assert abs(shown_dec - client.value("declination")) * 3600 < 5, (said, client.value("declination"))
    browser.save_screenshot(f"/tmp/alpaca-zwo-stopped-{size}.png")


@pytest.mark.parametrize("size", ["phone", "desktop"])
def test_a_horizon_refusal_names_the_line_the_person_sees(server_factory: ServerFactory, browser: WebDriver,
                                                          size: str) -> None:
    scene = Scene(server_factory, browser, size, "Vega")
    driver = scene.driver
    profile = driver.find_element(By.ID, "h-profile")
    tap(driver, profile)
    profile.clear()
    profile.send_keys("# the neighbour's trees\n0 10\n\n90 95")  # the server refuses its point 1: line 4 here
    tap(driver, driver.find_element(By.CSS_SELECTOR, "#form-horizon button[type='submit']"))
    beside = "#form-horizon + .refusal"
    WebDriverWait(driver, TIMEOUT).until(lambda d: d.find_elements(By.CSS_SELECTOR, beside))
    said = driver.find_element(By.CSS_SELECTOR, beside).text
    assert said.startswith("Horizon not saved: horizon line 4 altitude"), said
    assert "setup page" not in said and "limits." not in said and "point" not in said, said


@pytest.mark.parametrize("size", ["phone", "desktop"])
def test_a_field_the_browser_refuses_is_said_beside_its_form_in_the_pages_colours(
        server_factory: ServerFactory, browser: WebDriver, size: str) -> None:
    """Chrome's own validation bubble is grey and white, night mode or not: the page says it instead."""
    scene = Scene(server_factory, browser, size, "Vega")  # the phone in night mode
    driver = scene.driver
    elevation = driver.find_element(By.ID, "site-elev")
    tap(driver, elevation)
    elevation.clear()
    tap(driver, driver.find_element(By.CSS_SELECTOR, "#form-site button[type='submit']"))
    beside = "#form-site + .refusal"
    WebDriverWait(driver, TIMEOUT).until(lambda d: d.find_elements(By.CSS_SELECTOR, beside))
    said = driver.find_element(By.CSS_SELECTOR, beside).text
    assert said.startswith("Elevation m: ") and len(said) > len("Elevation m: "), said
    assert driver.execute_script("return document.activeElement.id") == "site-elev"
    colour = driver.execute_script("return getComputedStyle(document.querySelector(arguments[0])).color", beside)
    red, green, blue = (int(v) for v in re.findall(r"\d+", colour)[:3])
    if size == "phone":
        assert red > 0 and green == 0 and blue == 0, colour  # night mode: red light only
    else:
        assert red > green and red > blue, colour
    assert scene.client.settings()["site"]["elevation"] == 46.0  # nothing was sent


def _beside(driver: WebDriver, control: str) -> str:
    """The refusal under the row of ``control`` ('' when there is none)."""
    return str(driver.execute_script(
        "const next = document.getElementById(arguments[0]).closest('.row').nextElementSibling;"
        " return next && next.classList.contains('refusal') ? next.innerText : '';", control))


@pytest.mark.parametrize("size", ["phone", "desktop"])
def test_a_controls_refusal_is_beside_it_newest_only_and_cleared_by_its_next_success(
        server_factory: ServerFactory, browser: WebDriver, size: str) -> None:
    """With the mount parked, Home and then Tracking On are refused: each refusal is said under the row of the
    button that caused it (not in STOP's bar, over no control), the newest replacing the one before, both in the
    log; Unpark's success clears it."""
    scene = Scene(server_factory, browser, size, "Vega")
    driver, client = scene.driver, scene.client
    client.action("park")
    wait_until(lambda: client.status()["at_park"], 60, "the mount to park")
    WebDriverWait(driver, TIMEOUT).until(lambda d: d.find_element(By.ID, "btn-unpark").is_enabled())
    tap(driver, driver.find_element(By.ID, "btn-home"))
    WebDriverWait(driver, TIMEOUT).until(lambda d: _beside(d, "btn-home"))
    said = _beside(driver, "btn-home")
    assert said == ("The mount did not go home: going home is not allowed while the telescope is parked; "
                    "unpark it first"), said
    assert driver.find_element(By.ID, "messages").text == ""
    for control in ("btn-park", "btn-unpark", "btn-home", "btn-track-on", "btn-track-off", "btn-stop", "jog-s"):
        assert driver.execute_script(_HIT, control) == control, control
    driver.save_screenshot(f"/tmp/alpaca-zwo-refusal-home-{size}.png")

    tap(driver, driver.find_element(By.ID, "btn-track-on"))
    WebDriverWait(driver, TIMEOUT).until(lambda d: _beside(d, "btn-track-on"))
    assert _beside(driver, "btn-track-on").startswith("Tracking did not turn on: turning tracking on is not allowed")
    assert _beside(driver, "btn-home") == ""  # the newest only
    assert driver.execute_script("return document.querySelectorAll('.refusal').length") == 1
    for control in ("btn-track-on", "btn-track-off", "tracking-rate", "guide-rate", "btn-stop"):
        assert driver.execute_script(_HIT, control) == control, control
    logged = _log_messages(client)
    assert any("The mount did not go home: " in m for m in logged), logged
    assert any("Tracking did not turn on: " in m for m in logged), logged

    tap(driver, driver.find_element(By.ID, "btn-unpark"))
    WebDriverWait(driver, TIMEOUT).until(lambda d: "Unparked." in d.find_element(By.ID, "messages").text)
    assert driver.execute_script("return document.querySelectorAll('.refusal').length") == 0
