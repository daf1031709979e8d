"""The object card's GoTo verdict in real Chromium (issue 33 item 2, issue 43 point 8), at 390x844 (night
mode) and 1280x900 (day), north and at Sydney.

The mount's own altitude limit is set to 15° through the Alpaca Action ``zwo:AltitudeLimits``, as N.I.N.A.
or a script would, and Arcturus is put at about 10° rising (the site's longitude chosen for now): the card
names the mount's limit, and the GoTo button, instead of sending a slew the server must refuse, says when the
star comes up over that limit in the site's clock ("Not up: rises 21:47") and is disabled: nothing a tap
could send; Sync beside it is disabled with it, its name saying why (a sync says the telescope is centred
on the star, which the limits keep it from being). On the phone the star is then put well up: both take a
tap again. On the desktop the card follows the sky: Arcturus put just under the limit turns "reachable" and
its buttons back into GoTo and Sync by themselves as it rises through it (the emulator's clock runs at 4x),
without a new search, and that GoTo starts.
"""

from __future__ import annotations

import json
from datetime import datetime

import pytest
from selenium.webdriver.common.by import By
from selenium.webdriver.remote.webdriver import WebDriver
from selenium.webdriver.support.ui import WebDriverWait

from alpaca_zwo.catalogue import objects
from tests.browser.test_page_handset import TIMEOUT, Scene, button, shown, tap
from tests.conftest import ServerFactory
from tests.support.sites import NORTH, SYDNEY, Site
from tests.web.test_not_up import hour_angle_rising_at
from tests.web.test_setup_goto import _longitude_putting

STAR = "Arcturus"
LIMIT_WORDS = "below the mount's altitude limit of 15°"


def _put_at(scene: Scene, altitude: float) -> None:
    """Move the site so the star stands at ``altitude`` in the east now, by the mount's clock (at 4x, ahead
    of the wall clock by three times the test's age)."""
    star = objects.lookup(STAR)
    assert star.dec_deg is not None
    mount_now = datetime.fromisoformat(str(scene.client.value("utcdate")).replace("Z", "+00:00"))
    lon = _longitude_putting(star, ha_hours=hour_angle_rising_at(altitude, star.dec_deg, scene.latitude),
                             latitude=scene.latitude, now=mount_now)
    scene.client.change({"site": {"latitude": scene.latitude, "longitude": lon, "elevation": 46.0}})


def _fact(driver: WebDriver, term: str) -> str:
    """One fact of the card, read in one step (the card is rebuilt on each refresh)."""
    return str(driver.execute_script(
        "const t = [...document.querySelectorAll('#sel-facts dt')].find((dt) => dt.textContent === arguments[0]);"
        " return t && t.nextElementSibling ? t.nextElementSibling.textContent : '';", term))


def _limits_line(driver: WebDriver) -> str:
    return _fact(driver, "Limits")


def _goto_button(driver: WebDriver) -> tuple[str, bool]:
    """The GoTo button's words and whether it takes a tap, read in one step (the card is redrawn)."""
    words, enabled = driver.execute_script(
        "const b = document.getElementById('btn-goto'); return [b.textContent, !b.disabled];")
    return str(words), bool(enabled)


SYNC_NOT_UP = "Sync needs the telescope centred on it; it is not up"


def _sync_button(driver: WebDriver) -> tuple[str, bool, str]:
    """The Sync button's words, whether it takes a tap, and its accessible name as a screen reader gives it
    (aria-label, else its words), read in one step."""
    words, enabled, label = driver.execute_script(
        "const b = document.getElementById('btn-sync');"
        " return [b.textContent, !b.disabled, b.getAttribute('aria-label') || b.textContent];")
    return str(words), bool(enabled), str(label)


@pytest.mark.parametrize("site", [NORTH, SYDNEY], ids=lambda s: s.name)
@pytest.mark.parametrize("size", ["phone", "desktop"])
def test_under_the_mounts_limit_goto_says_when_it_rises_and_becomes_goto_then(
        server_factory: ServerFactory, browser: WebDriver, size: str, site: Site) -> None:
    scene = Scene(server_factory, browser, size, STAR, latitude=site.latitude)
    driver, client, model = scene.driver, scene.client, scene.model
    reply = client.command("action", Action="zwo:AltitudeLimits", Parameters=json.dumps({"enabled": True, "lower": 15}))
    assert json.loads(reply.value)["lower"] == 15
    _put_at(scene, 10.0)
    scene.find(STAR, False)
    WebDriverWait(driver, TIMEOUT).until(lambda d: scene.selected() == STAR)
    WebDriverWait(driver, TIMEOUT).until(lambda d: _limits_line(d) == LIMIT_WORDS)
    card = shown(driver, "selection")
    assert "above the horizon" not in card and "reachable" not in card, card
    body = client.session.get(f"{client.api}/object", params={"id": STAR}, timeout=TIMEOUT).json()
    assert 9.0 < body["altitude"] < 11.0
    # The button says when it is up over the 15° limit, in the site's clock, and cannot send a GoTo.
    words, enabled = _goto_button(driver)
    assert words.startswith("Not up: rises ") and not enabled, words
    assert words in (body["not_up"]["words"], client.session.get(  # the server's minute (a refresh may be later)
        f"{client.api}/object", params={"id": STAR}, timeout=TIMEOUT).json()["not_up"]["words"]), (words, body)
    assert body["not_up"]["rises"][-6:] == body["tonight"]["start"][-6:]  # the clock the card's times are in
    assert driver.find_elements(By.XPATH, "//button[normalize-space()='GoTo']") == []
    # Sync goes with GoTo: no tap, dashed like it, and its name says why.
    assert _sync_button(driver) == ("Sync", False, SYNC_NOT_UP)
    sync = driver.find_element(By.ID, "btn-sync")
    assert sync.get_attribute("title") == SYNC_NOT_UP
    assert sync.value_of_css_property("border-top-style") == "dashed"
    driver.save_screenshot(f"/tmp/alpaca-zwo-not-up-{site.name}-{size}.png")
    assert model.snapshot()["slew"] is None and not client.value("slewing")

    if size == "phone":
        # Well up: GoTo and Sync both take a tap again, on the card's own refresh.
        _put_at(scene, 30.0)
        WebDriverWait(driver, TIMEOUT).until(lambda d: _goto_button(d) == ("GoTo", True))
        WebDriverWait(driver, TIMEOUT).until(lambda d: _sync_button(d) == ("Sync", True, "Sync"))
        assert driver.find_element(By.ID, "btn-sync").get_dom_attribute("title") is None
    else:
        # Just under the limit and rising: the card turns reachable and GoTo comes back as the sky turns,
        # on the card's own refresh.
        _put_at(scene, 14.85)
        WebDriverWait(driver, TIMEOUT).until(  # the card at the new place (14.8° or 14.9°), still blocked
            lambda d: _fact(d, "Alt / Az").startswith("+14\u00b0") and _limits_line(d) == LIMIT_WORDS)
        assert _goto_button(driver)[0].startswith("Not up: rises ") and not _sync_button(driver)[1]
        WebDriverWait(driver, 60).until(lambda d: _limits_line(d) == "reachable: above the horizon and limits")
        WebDriverWait(driver, TIMEOUT).until(lambda d: _goto_button(d) == ("GoTo", True))
        assert _sync_button(driver) == ("Sync", True, "Sync")
        sync = driver.find_element(By.ID, "btn-sync")
        assert sync.get_dom_attribute("title") is None and sync.value_of_css_property("border-top-style") == "solid"
        tap(driver, button(driver, "GoTo"))
        WebDriverWait(driver, TIMEOUT).until(
            lambda d: f"GoTo {STAR} started." in d.find_element(By.TAG_NAME, "body").text)
