"""Headless Chromium, driven by Selenium, for the setup page tests.

Debian's ``chromium`` and ``chromium-driver`` packages are used by explicit path (scripts/run-tests
installs them), so Selenium never tries to download a browser or a driver of its own: the tests
must run with no internet, like the page itself.
"""

from __future__ import annotations

import shutil
import tempfile
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

CHROMIUM = Path("/usr/bin/chromium")
CHROMEDRIVER = Path("/usr/bin/chromedriver")


def _require(path: Path, package: str) -> str:
    if path.exists():
        return str(path)
    found = shutil.which(path.name)
    if found:
        return found
    pytest.fail(f"{path} not found: install it with `apt-get install -y {package}` (scripts/run-tests does)")


def _launch(extra_arguments: tuple[str, ...], profiles: list[str]) -> object:
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = _require(CHROMIUM, "chromium")
    profile = tempfile.mkdtemp(prefix="alpaca-zwo-chromium-")
    profiles.append(profile)
    for argument in ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                     "--disable-background-networking", "--disable-component-update", "--disable-sync",
                     "--disable-dev-shm-usage", "--window-size=1400,1000", f"--user-data-dir={profile}",
                     *extra_arguments):
        options.add_argument(argument)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(service=Service(_require(CHROMEDRIVER, "chromium-driver")), options=options)
    driver.set_page_load_timeout(30)
    return driver


@pytest.fixture
def browser_factory() -> Iterator[Callable[..., Any]]:
    """Start headless Chromiums with extra command-line arguments (e.g. ``--host-resolver-rules=...``);
    each has its own profile and all are quit afterwards."""
    drivers: list[Any] = []
    profiles: list[str] = []

    def start(*arguments: str) -> Any:
        driver = _launch(arguments, profiles)
        drivers.append(driver)
        return driver

    try:
        yield start
    finally:
        for driver in drivers:
            driver.quit()
        for profile in profiles:
            shutil.rmtree(profile, ignore_errors=True)


@pytest.fixture
def browser(browser_factory: Callable[..., Any]) -> object:
    """A fresh headless Chromium with its own profile, collecting the console log."""
    return browser_factory()
