"""The "Connect your software" box (issue 43 point 7), in real Chromium at 390x844 and 1280x900: the running
server's real port, its discovery state and the address programs use, and saved network settings told apart
from those in effect until a restart. The tests' servers listen on 127.0.0.1 only, with discovery off."""

from __future__ import annotations

import socket

import pytest
from selenium.webdriver.common.by import By
from selenium.webdriver.remote.webdriver import WebDriver
from selenium.webdriver.support.ui import WebDriverWait

from tests.browser.test_page_handset import SIZES, TIMEOUT, tap
from tests.conftest import ServerFactory
from tests.web.test_setup_api import Client


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return int(probe.getsockname()[1])


def _text(driver: WebDriver, element_id: str) -> str:
    element = driver.find_element(By.ID, element_id)
    return element.text if element.is_displayed() else ""


@pytest.mark.parametrize("size", ["phone", "desktop"])
def test_the_box_says_what_a_program_uses_now_and_what_waits_for_a_restart(server_factory: ServerFactory,
                                                                           browser: WebDriver, size: str) -> None:
    server = server_factory()
    client = Client(f"http://127.0.0.1:{server.port}")
    browser.set_window_size(*SIZES[size])
    browser.get(f"http://127.0.0.1:{server.port}/setup")
    WebDriverWait(browser, TIMEOUT).until(lambda d: _text(d, "connect-manual"))
    assert _text(browser, "connect-manual") == (f"By hand (Alpaca, manual entry): host 127.0.0.1, port {server.port}, "
                                                "device type Telescope, device number 0.")
    assert _text(browser, "connect-discovery").startswith("alpaca-zwo listens on this computer only (127.0.0.1)")
    assert _text(browser, "connect-pending") == ""

    port, discovery = _free_port(), _free_port()
    for field_id, value in (("n-port", port), ("n-disc", discovery)):
        field = browser.find_element(By.ID, field_id)
        tap(browser, field)
        field.clear()
        field.send_keys(str(value))
    tap(browser, browser.find_element(By.CSS_SELECTOR, "#form-server button[type='submit']"))
    WebDriverWait(browser, TIMEOUT).until(lambda d: "restart the server to apply them" in _text(d, "messages"))
    WebDriverWait(browser, TIMEOUT).until(lambda d: _text(d, "connect-pending"))
    assert _text(browser, "connect-pending") == (f"Saved, in effect after a restart: port {port}, discovery on UDP "
                                                 f"{discovery}. Until then the values above are the ones in effect.")
    assert f"port {server.port}," in _text(browser, "connect-manual")  # still the running one
    info = client.session.get(f"{client.base}/setup/api/server", timeout=TIMEOUT).json()
    assert info["port"] == server.port and info["configured"]["port"] == port
    assert info["connect"] == {"listening_on": "127.0.0.1", "only_this_machine": True, "addresses": ["127.0.0.1"],
                               "mdns_name": None}
    browser.save_screenshot(f"/tmp/alpaca-zwo-connect-{size}.png")
