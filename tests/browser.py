"""Debian's chromium driven by selenium, for the tests that look at a page in a real browser (the viewer, the compare
page), and a wait that says what it waited for."""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from pathlib import Path

from selenium import webdriver
from selenium.common.exceptions import StaleElementReferenceException
from selenium.webdriver.chrome.service import Service

CHROMIUM = "/usr/bin/chromium"
CHROMEDRIVER = "/usr/bin/chromedriver"


def chromium(window: str = "1500,1900") -> Iterator[webdriver.Chrome]:
    """A headless chromium for one test (a fixture body: `yield from chromium()`)."""
    if not (Path(CHROMIUM).is_file() and Path(CHROMEDRIVER).is_file()):
        raise FileNotFoundError(
            f"{CHROMIUM} and {CHROMEDRIVER} are needed (scripts/setup.sh installs Debian's "
            "chromium and chromium-driver)"
        )
    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for argument in (
        "--headless=new",
        "--no-sandbox",
        "--disable-dev-shm-usage",
        f"--window-size={window}",
        "--disable-gpu",
        "--hide-scrollbars",
    ):
        options.add_argument(argument)
    # An explicit driver path: selenium-manager is never asked to find or download anything.
    driver = webdriver.Chrome(service=Service(executable_path=CHROMEDRIVER), options=options)
    yield driver
    driver.quit()


def wait_for(what: str, check: Callable[[], object], timeout_s: float, describe: Callable[[], str]) -> object:
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        value = check()
        if value:
            return value
        time.sleep(0.5)
    raise AssertionError(f"timed out after {timeout_s:.0f} s waiting for {what}\n{describe()}")


def text_of(driver: webdriver.Chrome, element_id: str) -> str | None:
    """An element's text read in one script call, or None when it is absent. A page that rewrites its HTML every
    second replaces the element between a find and a read; one call cannot go stale."""
    return driver.execute_script(
        "const node = document.getElementById(arguments[0]); return node ? node.textContent : null;", element_id
    )


def click(driver: webdriver.Chrome, css: str, attempts: int = 5) -> None:
    """Click the element `css` finds, finding it again when the page rebuilt it between the find and the click."""
    for _ in range(attempts - 1):
        try:
            driver.find_element("css selector", css).click()
            return
        except StaleElementReferenceException:
            time.sleep(0.2)
    driver.find_element("css selector", css).click()
