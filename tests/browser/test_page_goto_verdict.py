"""The object card's GoTo verdict in real Chromium (issue 33 item 2), at 390x844 (night mode) and 1280x900.

The mount's own altitude limit is set to 15° through the Alpaca Action ``zwo:AltitudeLimits``, as N.I.N.A.
or a script would, and Arcturus is put at about 10° rising (the site's longitude chosen for now): the card
names the mount's limit, and a tap on GoTo is refused in the same words, by the server, with the emulator
not moved. On the desktop the card then follows the sky: Arcturus put just under the limit turns
"reachable" by itself as it rises through it (the emulator's clock runs at 4x), without a new search.
"""

from __future__ import annotations

import json
import math

import pytest
from selenium.webdriver.common.by import By
from selenium.webdriver.remote.webdriver import WebDriver
from selenium.webdriver.support.ui import WebDriverWait

from alpaca_zwo.catalogue import objects
from tests.browser.test_page_handset import TIMEOUT, Scene, button, shown, tap
from tests.conftest import ServerFactory
from tests.web.test_setup_goto import LATITUDE, _longitude_putting

STAR = "Arcturus"
LIMIT_WORDS = "below the mount's altitude limit of 15°"


def _hour_angle_rising_at(altitude: float, dec: float, latitude: float = LATITUDE) -> float:
    """The (negative: east, rising) hour angle in hours at which a star at ``dec`` stands at ``altitude``."""
    phi, delta = math.radians(latitude), math.radians(dec)
    cos_h = (math.sin(math.radians(altitude)) - math.sin(phi) * math.sin(delta)) / (math.cos(phi) * math.cos(delta))
    return -math.degrees(math.acos(cos_h)) / 15.0


def _put_at(scene: Scene, altitude: float) -> None:
    """Move the site so the star stands at ``altitude`` in the east now."""
    star = objects.lookup(STAR)
    assert star.dec_deg is not None
    lon = _longitude_putting(star, ha_hours=_hour_angle_rising_at(altitude, star.dec_deg))
    scene.client.change({"site": {"latitude": LATITUDE, "longitude": lon, "elevation": 46.0}})


def _fact(driver: WebDriver, term: str) -> str:
    """One fact of the card, read in one step (the card is rebuilt on each refresh)."""
    return str(driver.execute_script(
        "const t = [...document.querySelectorAll('#sel-facts dt')].find((dt) => dt.textContent === arguments[0]);"
        " return t && t.nextElementSibling ? t.nextElementSibling.textContent : '';", term))


def _limits_line(driver: WebDriver) -> str:
    return _fact(driver, "Limits")


@pytest.mark.parametrize("size", ["phone", "desktop"])
def test_the_card_names_the_mounts_altitude_limit_and_goto_is_refused(server_factory: ServerFactory,
                                                                       browser: WebDriver, size: str) -> None:
    scene = Scene(server_factory, browser, size, STAR)
    driver, client, model = scene.driver, scene.client, scene.model
    reply = client.command("action", Action="zwo:AltitudeLimits", Parameters=json.dumps({"enabled": True, "lower": 15}))
    assert json.loads(reply.value)["lower"] == 15
    _put_at(scene, 10.0)
    scene.find(STAR, False)
    WebDriverWait(driver, TIMEOUT).until(lambda d: scene.selected() == STAR)
    WebDriverWait(driver, TIMEOUT).until(lambda d: _limits_line(d) == LIMIT_WORDS)
    card = shown(driver, "selection")
    assert "above the horizon" not in card and "reachable" not in card, card
    altitude = client.session.get(f"{client.api}/object", params={"id": STAR}, timeout=TIMEOUT).json()["altitude"]
    assert 9.0 < altitude < 11.0
    driver.save_screenshot(f"/tmp/alpaca-zwo-verdict-limit-{size}.png")
    before = model.snapshot()
    tap(driver, button(driver, "GoTo"))
    WebDriverWait(driver, TIMEOUT).until(
        lambda d: f"GoTo {STAR} refused: target is {LIMIT_WORDS}" in d.find_element(By.TAG_NAME, "body").text)
    after = model.snapshot()
    assert after["slew"] is None and after["target_ra_h"] == before["target_ra_h"]  # the mount was never asked

    if size == "desktop":
        # Just under the limit and rising: the card turns reachable as the sky turns, on its own refresh.
        _put_at(scene, 14.85)
        WebDriverWait(driver, TIMEOUT).until(  # the card at the new place (14.8° or 14.9°), still blocked
            lambda d: _fact(d, "Alt / Az").startswith("+14\u00b0") and _limits_line(d) == LIMIT_WORDS)
        WebDriverWait(driver, 60).until(lambda d: _limits_line(d) == "reachable: above the horizon and limits")
        tap(driver, button(driver, "GoTo"))
        WebDriverWait(driver, TIMEOUT).until(
            lambda d: f"GoTo {STAR} started." in d.find_element(By.TAG_NAME, "body").text)
