"""The hand controller a visual observer trusts in the dark (issue 33 items 1, 4, 5, 8), in real Chromium at
390x844 and 1280x900.

STOP is judged by its box on the screen (getBoundingClientRect, CSS pixels) and by what is drawn at its
corners and centre (elementFromPoint): the same box, never covered, in every state and scroll position.
The Escape key is judged by the mount: Alpaca's Slewing and the emulator's axes. Night mode is judged on
the screenshot's pixels (no green or blue light) and on the page's state when its body is first parsed,
before any frame is drawn. axe-core 4 (vendored in tests/browser/axe/, MPL-2.0) judges accessibility.
Screenshots go to /tmp (docs/screenshots/ holds the ones looked at).
"""

from __future__ import annotations

import json
import re
from pathlib import Path
from typing import Any

import pytest
from selenium.webdriver.common.action_chains import ActionChains
from selenium.webdriver.common.actions.action_builder import ActionBuilder
from selenium.webdriver.common.by import By
from selenium.webdriver.common.keys import Keys
from selenium.webdriver.remote.webdriver import WebDriver
from selenium.webdriver.support.ui import Select, WebDriverWait

from alpaca_zwo.catalogue import objects
from alpaca_zwo.config.settings import EmulatorSettings, SiteSettings
from alpaca_zwo.emulator import MountModel
from alpaca_zwo.server import AlpacaZwoServer
from tests.browser.pixels import rgb_pixels
from tests.conftest import ServerFactory, make_settings
from tests.support import wait_until
from tests.web.test_setup_api import Client
from tests.web.test_setup_goto import LATITUDE, SPEED, _longitude_putting

TIMEOUT = 20
SIZES = {"phone": (390, 844), "desktop": (1280, 900)}
AXE = Path(__file__).parent / "axe" / "axe.min.js"
#: Green or blue at or below this is anti-aliasing's rounding, not light (a red edge on black stays red).
STRAY = 8
#: Alpaca member names a person at the page never typed.
JARGON = re.compile(r"Async|SlewTo|SyncTo|AbortSlew|MoveAxis|PulseGuide|FindHome|SideOfPier|Tracking=")


class Page:
    """A server on a 4x emulator clock with Vega 1.5 h east of the meridian, and the page open at ``size``."""

    def __init__(self, server_factory: ServerFactory, driver: WebDriver, size: str, *, night: bool = False) -> None:
        lon = _longitude_putting(objects.lookup("Vega"), latitude=LATITUDE)
        self.server: AlpacaZwoServer = server_factory(make_settings(
            site=SiteSettings(latitude=LATITUDE, longitude=lon, elevation=46.0),
            emulator=EmulatorSettings(speed=SPEED, baud=0)))
        self.url = f"http://127.0.0.1:{self.server.port}/setup"
        self.client = Client(f"http://127.0.0.1:{self.server.port}")
        self.client.command("connected", Connected="true")
        wait_until(lambda: self.client.status()["position"] is not None, what="a first position")
        emulator = self.server.emulators[0]
        assert emulator is not None
        self.model: MountModel = emulator.model
        self.driver = driver
        self.size = size
        driver.set_window_size(*SIZES[size])
        driver.get(self.url)
        if night:  # the stored choice, as a person who switched it on last night finds it
            driver.execute_script("localStorage.setItem('alpaca-zwo-night', '1')")
        self.load()

    def load(self) -> None:
        self.driver.get(self.url)
        WebDriverWait(self.driver, TIMEOUT).until(
            lambda d: d.find_element(By.ID, "link-pill").text.startswith("mount: connected"))

    def js(self, script: str, *args: Any) -> Any:
        return self.driver.execute_script(script, *args)

    def stop_box(self) -> tuple[float, float, float, float]:
        box = self.js("const r = document.getElementById('btn-stop').getBoundingClientRect();"
                      " return [r.left, r.top, r.width, r.height];")
        return tuple(round(v, 1) for v in box)

    def assert_stop_uncovered(self, where: str) -> None:
        """STOP inside the window, and STOP is what is drawn at its centre and near its four corners."""
        left, top, width, height = self.stop_box()
        inner = self.js("return [window.innerWidth, window.innerHeight]")
        assert left >= 0 and top >= 0 and left + width <= inner[0] and top + height <= inner[1], (where, inner)
        points = [(left + width / 2, top + height / 2), (left + 4, top + 4), (left + width - 4, top + 4),
                  (left + 4, top + height - 4), (left + width - 4, top + height - 4)]
        for x, y in points:
            hit = self.js("const e = document.elementFromPoint(arguments[0], arguments[1]); return e &&"
                          " (e.closest('#btn-stop') ? 'STOP' : e.tagName + '#' + e.id + '.' + e.className);", x, y)
            assert hit == "STOP", (where, (x, y), hit)

    def place(self, element_id: str) -> tuple[float, float]:
        """Where an element is in the Controls card: it moves only if something in the card pushed it. (The
        clock and site line at the top of the page, issue 31's, moves the whole grid when it appears.)"""
        found = self.js("const r = document.getElementById(arguments[0]).getBoundingClientRect();"
                        " const c = document.querySelector('.controls-card').getBoundingClientRect();"
                        " return [r.left - c.left, r.top - c.top];", element_id)
        return round(found[0], 1), round(found[1], 1)

    def find(self, text: str) -> None:
        field = self.driver.find_element(By.ID, "find")
        self.js("arguments[0].scrollIntoView({block: 'center'})", field)
        field.click()
        field.clear()
        field.send_keys(text, Keys.ENTER)
        name = text
        WebDriverWait(self.driver, TIMEOUT).until(lambda d: d.find_element(By.ID, "sel-name").text == name)

    def tap(self, element_id: str) -> None:
        element = self.driver.find_element(By.ID, element_id)
        self.js("arguments[0].scrollIntoView({block: 'center'})", element)
        element.click()

    def tap_on_chart(self, star: str) -> None:
        """A real pointer tap on the star's dot on the chart (scrolled to the middle of the screen first)."""
        dot = f"#sky-chart circle[data-name='{star}']"
        WebDriverWait(self.driver, TIMEOUT).until(lambda d: d.find_elements(By.CSS_SELECTOR, dot))
        self.js("document.getElementById('sky').scrollIntoView({block: 'center'})")
        x, y = self.js("const r = document.querySelector(arguments[0]).getBoundingClientRect();"
                       " return [r.left + r.width / 2, r.top + r.height / 2];", dot)
        actions = ActionBuilder(self.driver)
        actions.pointer_action.move_to_location(round(x), round(y)).click()
        actions.perform()
        WebDriverWait(self.driver, TIMEOUT).until(lambda d: d.find_element(By.ID, "sel-name").text == star)

    def refused_goto(self, star: str) -> None:
        """Park the mount, choose a star that is up and tap GoTo: the server refuses it (unpark first), and
        the refusal shows beside the buttons. (A star that is down gets neither a GoTo nor a Sync to refuse.)"""
        self.client.action("park")
        wait_until(lambda: self.client.status()["at_park"], 60, "the mount to park")
        # the page's next poll ends its "Parking at …" line: the view shows the refusal alone
        WebDriverWait(self.driver, TIMEOUT).until(lambda d: not d.find_element(By.ID, "progress").is_displayed())
        self.find(star)
        self.tap("btn-goto")
        WebDriverWait(self.driver, TIMEOUT).until(
            lambda d: any(f"GoTo {star} refused" in e for e in self.errors()))

    def unpark(self) -> None:
        self.client.action("unpark")
        wait_until(lambda: not self.client.status()["at_park"], TIMEOUT, "the mount to unpark")

    def messages(self) -> str:
        return str(self.js("return document.getElementById('messages').innerText"))

    def errors(self) -> list[str]:
        """The error in the message place and the refusals shown beside the controls that caused them."""
        return list(self.js("return [...document.querySelectorAll('#messages .msg.error, .refusal')]"
                            ".map((e) => e.innerText)"))

    def shot(self, name: str) -> bytes:
        png: bytes = self.driver.get_screenshot_as_png()
        Path(f"/tmp/alpaca-zwo-{name}-{self.size}.png").write_bytes(png)
        return png


def _slewing(client: Client) -> bool:
    return bool(client.value("slewing"))


@pytest.mark.parametrize("size", ["phone", "desktop"])
def test_stop_never_moves_and_is_never_covered(server_factory: ServerFactory, browser: WebDriver, size: str) -> None:
    page = Page(server_factory, browser, size)
    home = page.stop_box()
    page.assert_stop_uncovered("at first")
    seen = {"at first": home}

    page.find("Vega")
    jog = {"before the GoTo": page.place("jog-n")}
    page.tap("btn-goto")
    WebDriverWait(browser, TIMEOUT).until(lambda d: "GoTo Vega started." in page.messages())
    seen["a message showing"] = page.stop_box()
    page.assert_stop_uncovered("a message showing")
    WebDriverWait(browser, TIMEOUT).until(lambda d: d.find_element(By.ID, "progress").is_displayed())
    seen["during the GoTo"] = page.stop_box()
    jog["during the GoTo"] = page.place("jog-n")
    page.shot("stop-goto")
    WebDriverWait(browser, 120).until(lambda d: d.find_element(By.ID, "arrival").is_displayed())
    seen["after the GoTo"] = page.stop_box()
    jog["after the GoTo"] = page.place("jog-n")
    page.assert_stop_uncovered("the arrival line showing")
    # the progress and arrival lines and the messages push no control: the jog pad stays where it was
    assert len(set(jog.values())) == 1, jog

    page.refused_goto("Vega")  # the mount parked
    seen["after a refused GoTo"] = page.stop_box()
    page.assert_stop_uncovered("after a refused GoTo")
    page.shot("stop-refused")

    page.js("document.getElementById('sky').scrollIntoView({block: 'start'})")
    seen["scrolled to the chart"] = page.stop_box()
    page.assert_stop_uncovered("scrolled to the chart")
    page.js("window.scrollTo(0, document.documentElement.scrollHeight)")
    seen["scrolled to the end"] = page.stop_box()
    page.assert_stop_uncovered("scrolled to the end")
    # the page is padded: its last line is above STOP's bar, not under it
    footer = page.js("return document.getElementById('footer').getBoundingClientRect().bottom")
    bar = page.js("return document.querySelector('.stop-bar').getBoundingClientRect().top")
    assert footer <= bar, (footer, bar)
    assert all(box == home for box in seen.values()), seen
    assert page.js("return document.getElementById('btn-stop').getAttribute('aria-keyshortcuts')") == "Escape"


@pytest.mark.parametrize("size", ["phone", "desktop"])
def test_escape_stops_the_mount_whatever_has_focus(server_factory: ServerFactory, browser: WebDriver,
                                                   size: str) -> None:
    page = Page(server_factory, browser, size)
    field = browser.find_element(By.ID, "find")
    for focus in ("find", "h-profile"):
        r = page.client.post("/setup/api/telescope/0/goto", {"id": "Vega"})
        assert r.status_code == 200, r.text
        wait_until(lambda: _slewing(page.client), TIMEOUT, "the slew to start")
        if focus == "find":  # typing a search, its list of matches open
            page.js("arguments[0].scrollIntoView({block: 'center'})", field)
            field.click()
            field.clear()
            field.send_keys("Mar")
            WebDriverWait(browser, TIMEOUT).until(lambda d: field.get_attribute("aria-expanded") == "true")
        else:  # a text area of the settings
            page.tap(focus)
        assert page.js("return document.activeElement.id") == focus
        ActionChains(browser).send_keys(Keys.ESCAPE).perform()
        wait_until(lambda: not _slewing(page.client), 5, f"Escape in #{focus} to stop the slew")
        wait_until(lambda: page.model.snapshot()["velocity_deg_s"][1] == 0.0, 5, "the Dec axis to rest")
        assert abs(page.model.snapshot()["velocity_deg_s"][0]) < 0.01  # at most tracking
        WebDriverWait(browser, TIMEOUT).until(  # "before reaching the target" when a poll saw the slew run
            lambda d: d.find_element(By.ID, "arrival").text.startswith("Stopped"))
        if focus == "find":  # and the same key still closed the list it was pressed in
            assert field.get_attribute("aria-expanded") == "false"
            assert not browser.find_element(By.ID, "find-list").is_displayed()


@pytest.mark.parametrize("size", ["phone", "desktop"])
def test_an_error_clears_with_the_next_success_in_plain_words(server_factory: ServerFactory, browser: WebDriver,
                                                              size: str) -> None:
    page = Page(server_factory, browser, size)
    profile = browser.find_element(By.ID, "h-profile")
    page.tap("h-profile")
    profile.clear()
    profile.send_keys("north 15")
    save = browser.find_element(By.CSS_SELECTOR, "#form-horizon button[type='submit']")
    page.js("arguments[0].click()", save)
    WebDriverWait(browser, TIMEOUT).until(lambda d: any("horizon line 1" in e for e in page.errors()))
    profile.clear()
    profile.send_keys("0 15")
    page.js("arguments[0].click()", save)
    WebDriverWait(browser, TIMEOUT).until(lambda d: "Horizon saved." in page.messages())
    assert page.errors() == []

    page.client.action("park")
    wait_until(lambda: page.client.status()["at_park"], 60, "the mount to park")
    page.find("Vega")
    page.tap("btn-goto")
    WebDriverWait(browser, TIMEOUT).until(lambda d: any("parked" in e for e in page.errors()))
    said = " ".join(page.errors())
    assert not JARGON.search(said), said
    assert "GoTo Vega refused: " in said and "unpark it first" in said, said
    page.shot("error-parked")
    WebDriverWait(browser, TIMEOUT).until(lambda d: d.find_element(By.ID, "btn-unpark").is_enabled())
    page.tap("btn-unpark")
    WebDriverWait(browser, TIMEOUT).until(lambda d: "Unparked." in page.messages())
    assert page.errors() == []


@pytest.mark.parametrize("size", ["phone", "desktop"])
def test_the_time_source_is_chosen_on_the_page(server_factory: ServerFactory, browser: WebDriver, size: str) -> None:
    page = Page(server_factory, browser, size)
    choice = Select(browser.find_element(By.ID, "t-source"))
    assert choice.first_selected_option.get_attribute("value") == "auto"
    page.tap("t-source")
    choice.select_by_value("mount")
    page.js("arguments[0].click()", browser.find_element(By.CSS_SELECTOR, "#form-time button[type='submit']"))
    WebDriverWait(browser, TIMEOUT).until(lambda d: "Time source saved" in page.messages())
    assert page.server.settings.time.source == "mount"  # in effect: the time keeper reads it on each decision
    assert page.client.settings()["time"] == {"source": "mount"}
    page.load()
    choice = Select(browser.find_element(By.ID, "t-source"))
    WebDriverWait(browser, TIMEOUT).until(lambda d: choice.first_selected_option.get_attribute("value") == "mount")


@pytest.mark.parametrize("size", ["phone", "desktop"])
def test_a_star_tapped_on_the_chart_shows_its_card_with_goto_in_view(server_factory: ServerFactory,
                                                                    browser: WebDriver, size: str) -> None:
    page = Page(server_factory, browser, size, night=size == "phone")
    page.tap_on_chart("Vega")
    inner = page.js("return [window.innerWidth, window.innerHeight]")
    stop_top = page.stop_box()[1]
    goto = page.js("const r = document.getElementById('btn-goto').getBoundingClientRect();"
                   " return [r.left, r.top, r.right, r.bottom];")
    assert goto[0] >= 0 and goto[2] <= inner[0] and goto[1] >= 0 and goto[3] <= stop_top, (goto, inner, stop_top)
    hit = page.js("const e = document.elementFromPoint(arguments[0], arguments[1]); return e && e.id;",
                  (goto[0] + goto[2]) / 2, (goto[1] + goto[3]) / 2)
    assert hit == "btn-goto", hit
    # ... and the chart with the star just tapped, its selection ring drawn, in view above the card
    WebDriverWait(browser, TIMEOUT).until(lambda d: page.js("return !!document.getElementById('sky-selected')"))
    ring = page.js("const r = document.getElementById('sky-selected').getBoundingClientRect();"
                   " return [r.left + r.width / 2, r.top + r.height / 2];")
    chart = page.js("const r = document.getElementById('sky').getBoundingClientRect(); return [r.top, r.bottom];")
    assert ring[1] >= 0 and (ring[1] < goto[1] or size == "desktop"), (ring, goto)
    hit = page.js("const e = document.elementFromPoint(arguments[0], arguments[1]); return e && !!e.closest('#sky');",
                  *ring)
    assert hit, "the tapped star is covered"
    if size == "phone":
        assert chart[0] >= 0 and chart[1] <= goto[1], (chart, goto)  # the whole chart above the card
    page.shot("chart-card")
    browser.find_element(By.ID, "btn-goto").click()
    WebDriverWait(browser, TIMEOUT).until(lambda d: "Slewing to Vega" in d.find_element(By.ID, "progress").text)
    # the motion line in view too (above STOP on a phone, beside it on a desktop), nothing over it
    progress = page.js("const r = document.getElementById('progress').getBoundingClientRect();"
                       " return [r.left, r.top, r.right, r.bottom];")
    assert progress[0] >= 0 and progress[1] >= 0 and progress[2] <= inner[0] and progress[3] <= inner[1], progress
    hit = page.js("const e = document.elementFromPoint(arguments[0], arguments[1]); return e && e.id;",
                  (progress[0] + progress[2]) / 2, (progress[1] + progress[3]) / 2)
    assert hit == "progress", hit
    if size == "phone":  # × puts the card back in the hand controller
        browser.find_element(By.ID, "sel-close").click()
        assert page.js("return !!document.getElementById('selection').closest('#handset')")


def _stray(png: bytes) -> tuple[int, int, list[tuple[int, int, int]]]:
    pixels = rgb_pixels(png)
    stray = [p for p in pixels if max(p[1], p[2]) > STRAY]
    return len(pixels), len(stray), stray[:8]


@pytest.mark.parametrize("size", ["phone", "desktop"])
def test_night_mode_is_red_light_only_in_every_view(server_factory: ServerFactory, browser: WebDriver,
                                                    size: str) -> None:
    """Placeholders, checkboxes, selects, the dimmer, STOP, messages, the chart with the Sun and the flip line,
    and the phone's sheet: no pixel of any view carries green or blue light."""
    page = Page(server_factory, browser, size, night=True)
    page.client.change({"meridian": {"track_after": True, "limit_degrees": 10},
                        "mount_limits": {"enabled": True, "upper": 85, "lower": 10}})
    views: dict[str, bytes] = {}
    page.js("window.scrollTo(0, 0)")
    views["top"] = page.shot("night-top")  # the search field's placeholder, the header, STOP
    for form in ("form-meridian", "form-park", "form-observatory", "form-server"):  # checkboxes, selects
        page.js(f"document.getElementById('{form}').scrollIntoView({{block: 'center'}})")
        views[form] = page.shot(f"night-{form}")
    field = browser.find_element(By.ID, "find")
    page.js("arguments[0].scrollIntoView({block: 'center'})", field)
    field.click()
    field.send_keys("Mar")
    WebDriverWait(browser, TIMEOUT).until(lambda d: field.get_attribute("aria-expanded") == "true")
    views["matches"] = page.shot("night-matches")
    field.send_keys(Keys.ESCAPE)
    page.refused_goto("Altair")  # a refusal beside the buttons
    views["error"] = page.shot("night-error")
    page.unpark()
    WebDriverWait(browser, TIMEOUT).until(lambda d: d.find_elements(By.CSS_SELECTOR, "#sky-chart .sky-body.sun"))
    page.tap_on_chart("Vega")
    views["chart"] = page.shot("night-chart")
    browser.find_element(By.ID, "btn-goto").click()  # the slewing telescope, its target, the motion line
    WebDriverWait(browser, TIMEOUT).until(lambda d: " left" in d.find_element(By.ID, "progress").text)
    views["goto"] = page.shot("night-goto")
    report = {name: _stray(png) for name, png in views.items()}
    assert all(stray == 0 for _, stray, _ in report.values()), report
    lit = [p for p in rgb_pixels(views["top"]) if p[0] > 150]
    assert len(lit) > 500  # it is drawn, in red


# Run before any of the page's scripts: what <html> is when the parser inserts <body> (before the first
# frame can be drawn, and before the deferred app.js runs), and at DOMContentLoaded.
FIRST_PAINT_PROBE = """
window.__probe = {};
const look = () => ({night: document.documentElement.classList.contains('night'),
                     dim: getComputedStyle(document.documentElement).getPropertyValue('--dim').trim(),
                     background: document.body ? getComputedStyle(document.body).backgroundColor : null});
new MutationObserver((records, observer) => {
  if (document.body && !window.__probe.body) { window.__probe.body = look(); observer.disconnect(); }
}).observe(document, {childList: true, subtree: true});
document.addEventListener('DOMContentLoaded', () => { window.__probe.ready = look(); });
"""


def _probe(page: Page) -> dict[str, Any]:
    page.load()
    return dict(page.js("return window.__probe"))


@pytest.mark.parametrize("size", ["phone", "desktop"])
def test_night_mode_and_the_dimmer_are_on_before_the_first_paint(server_factory: ServerFactory, browser: WebDriver,
                                                                 size: str) -> None:
    page = Page(server_factory, browser, size, night=True)
    # the dimmer, by keyboard: from 100% down to 40%, remembered
    dim = browser.find_element(By.ID, "dim")
    page.js("arguments[0].scrollIntoView({block: 'center'})", dim)
    before = max(p[0] for p in rgb_pixels(page.shot("dim-before")))
    dim.click()
    dim.send_keys(Keys.END)
    dim.send_keys(*[Keys.ARROW_LEFT] * 12)
    assert dim.get_attribute("value") == "40"
    assert page.js("return getComputedStyle(document.documentElement).filter") == "brightness(0.4)"
    after = max(p[0] for p in rgb_pixels(page.shot("dim-after")))
    assert after <= before * 0.4 + 3, (before, after)

    browser.execute_cdp_cmd("Page.addScriptToEvaluateOnNewDocument", {"source": FIRST_PAINT_PROBE})
    probe = _probe(page)
    assert probe["body"] == {"night": True, "dim": "0.4", "background": probe["body"]["background"]}, probe
    assert probe["ready"]["background"] == "rgb(0, 0, 0)", probe
    assert browser.find_element(By.ID, "dim").get_attribute("value") == "40"
    assert browser.find_element(By.ID, "btn-night").get_attribute("aria-pressed") == "true"
    # The probe can fail: without night.js the page turns red only when app.js runs, after the body is parsed.
    browser.execute_cdp_cmd("Network.enable", {})
    browser.execute_cdp_cmd("Network.setBlockedURLs", {"urls": ["*night.js"]})
    late = _probe(page)
    assert late["body"]["night"] is False and late["body"]["dim"] == "", late


def _axe(page: Page) -> list[dict[str, Any]]:
    page.driver.set_script_timeout(120)
    page.js(AXE.read_text(encoding="utf-8"))
    found: list[dict[str, Any]] = page.driver.execute_async_script(
        "const done = arguments[arguments.length - 1];"
        " axe.run(document, {resultTypes: ['violations']}).then((r) => done(r.violations.map((v) => ({"
        "  id: v.id, impact: v.impact, nodes: v.nodes.map((n) => n.target.join(' ')).slice(0, 6)}))),"
        " (e) => done([{id: 'axe failed', impact: 'critical', nodes: [String(e)]}]));")
    return found


@pytest.mark.parametrize("size", ["phone", "desktop"])
@pytest.mark.parametrize("night", [False, True], ids=["day", "night"])
def test_axe_finds_no_serious_or_critical_violation(server_factory: ServerFactory, browser: WebDriver, size: str,
                                                    night: bool) -> None:
    """With the diagnostics open, an object's card and a list of matches showing, then with a star tapped on the
    chart (a phone's sheet) and a GoTo's motion line; in night mode only
    color-contrast may remain (dim red on black on purpose: docs/guide/hand-controller.md, "Night mode and
    brightness")."""
    page = Page(server_factory, browser, size, night=night)
    page.js("for (const d of document.querySelectorAll('details')) d.open = true")
    page.find("Vega")
    field = browser.find_element(By.ID, "find")
    field.clear()
    field.send_keys("Mar")
    WebDriverWait(browser, TIMEOUT).until(lambda d: field.get_attribute("aria-expanded") == "true")
    WebDriverWait(browser, TIMEOUT).until(lambda d: d.find_elements(By.CSS_SELECTOR, "#trace tr"))
    found = _axe(page)
    field.send_keys(Keys.ESCAPE)
    page.tap_on_chart("Vega")  # on a phone: the card as a sheet in the dock; then a GoTo's motion line
    browser.find_element(By.ID, "btn-goto").click()
    WebDriverWait(browser, TIMEOUT).until(lambda d: d.find_element(By.ID, "progress").is_displayed())
    found += _axe(page)
    bad = [v for v in found if v["impact"] in ("serious", "critical") and not (night and v["id"] == "color-contrast")]
    Path(f"/tmp/alpaca-zwo-axe-{size}-{'night' if night else 'day'}.json").write_text(json.dumps(found, indent=1))
    assert bad == [], json.dumps(bad, indent=1)
