"""The guide from the page, at phone size (issue 42): the Help link and a setting's "?" open the guide served
by the server itself, readable on a phone (no sideways scrolling, text at a readable size, the section
in view) and, in night mode, in red light only, screenshots included. Screenshots go to /tmp
(/tmp/alpaca-zwo-guide-*-phone.png)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from selenium.webdriver.common.by import By
from selenium.webdriver.remote.webdriver import WebDriver
from selenium.webdriver.support.ui import WebDriverWait

from alpaca_zwo.server import AlpacaZwoServer
from tests.browser.pixels import rgb_pixels

PHONE = (390, 844)
TIMEOUT = 20
STRAY = 8  # a green or blue channel above this is light that is not red (as test_page_in_the_dark.py)


def _follow(browser: WebDriver, link: Any) -> None:
    """Tap a link that opens the guide in a new tab, and move to that tab once it has loaded."""
    before = set(browser.window_handles)
    link.click()
    WebDriverWait(browser, TIMEOUT).until(lambda d: len(set(d.window_handles) - before) == 1)
    browser.switch_to.window((set(browser.window_handles) - before).pop())
    WebDriverWait(browser, TIMEOUT).until(
        lambda d: d.execute_script("return document.readyState") == "complete" and "/docs" in d.current_url)


def _readable_on_a_phone(browser: WebDriver) -> None:
    width = browser.execute_script("return [document.documentElement.scrollWidth, window.innerWidth]")
    assert width[0] <= width[1], f"the guide scrolls sideways on a phone: {width}"
    size = browser.execute_script("return parseFloat(getComputedStyle(document.querySelector('main p')).fontSize)")
    assert size >= 16


def test_help_and_a_settings_question_mark_open_the_guide_on_a_phone(live_server: AlpacaZwoServer,
                                                                      browser: WebDriver) -> None:
    browser.set_window_size(*PHONE)
    setup = f"http://127.0.0.1:{live_server.port}/setup"
    browser.get(setup)
    page = browser.current_window_handle
    _follow(browser, browser.find_element(By.ID, "help-link"))
    assert browser.current_url.endswith("/docs")
    assert browser.find_element(By.TAG_NAME, "h1").text == "The alpaca-zwo guide"
    _readable_on_a_phone(browser)
    browser.find_element(By.LINK_TEXT, "The first night").click()  # a page from the contents
    WebDriverWait(browser, TIMEOUT).until(lambda d: d.current_url.endswith("/docs/first-night"))
    _readable_on_a_phone(browser)

    browser.switch_to.window(page)
    question = browser.find_element(By.CSS_SELECTOR, "a.help[aria-label='Help: meridian flip']")
    browser.execute_script("arguments[0].scrollIntoView({block: 'center'})", question)
    _follow(browser, question)
    assert browser.current_url.endswith("/docs/mount-settings#meridian-flip")
    box = browser.execute_script("const r = document.getElementById('meridian-flip').getBoundingClientRect();"
                                 "const top = document.querySelector('.guide-top').getBoundingClientRect();"
                                 "return [r.top, r.bottom, top.bottom, window.innerHeight]")
    assert box[2] <= box[0] + 1 and box[1] <= box[3], f"the section's heading is not in view: {box}"
    _readable_on_a_phone(browser)
    browser.save_screenshot("/tmp/alpaca-zwo-guide-section-phone.png")


def test_the_guide_in_night_mode_is_red_light_only(live_server: AlpacaZwoServer, browser: WebDriver) -> None:
    browser.set_window_size(*PHONE)
    base = f"http://127.0.0.1:{live_server.port}"
    browser.get(base + "/setup")
    browser.find_element(By.ID, "btn-night").click()  # the page's own switch; the guide reads the same choice
    WebDriverWait(browser, TIMEOUT).until(
        lambda d: d.execute_script("return document.documentElement.classList.contains('night')"))
    browser.get(base + "/docs/hand-controller")
    assert browser.execute_script("return document.documentElement.classList.contains('night')")
    shot = browser.find_element(By.CSS_SELECTOR, ".guide .shot img")
    browser.execute_script("arguments[0].scrollIntoView({block: 'start'})", shot)
    WebDriverWait(browser, TIMEOUT).until(lambda d: d.execute_script(
        "const i = document.querySelector('.guide .shot img'); return i.complete && i.naturalWidth > 0"))
    png = browser.get_screenshot_as_png()
    Path("/tmp/alpaca-zwo-guide-night-phone.png").write_bytes(png)
    pixels = rgb_pixels(png)
    stray = [p for p in pixels if max(p[1], p[2]) > STRAY]
    assert stray == [], f"{len(stray)} of {len(pixels)} pixels carry green or blue light, e.g. {stray[:8]}"
    assert len([p for p in pixels if p[0] > 60]) > 1000, "the screenshot and the text are drawn, in red"


def test_no_page_of_the_guide_scrolls_sideways_on_a_phone(live_server: AlpacaZwoServer, browser: WebDriver) -> None:
    """Wide tables (the configuration keys, the clients) scroll inside themselves, never the page."""
    browser.set_window_size(*PHONE)
    base = f"http://127.0.0.1:{live_server.port}"
    browser.get(base + "/docs")
    pages = browser.execute_script("return [...document.querySelectorAll('.guide-nav a')].map((a) => a.href)")
    assert len(pages) >= 15
    for page in pages:
        browser.get(page)
        _readable_on_a_phone(browser)
