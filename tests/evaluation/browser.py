"""Headless Chromium for the HTML report's tests: Debian's ``chromium`` and ``chromium-driver``
(``make test`` installs them), driven through Selenium with the driver named, so nothing is
looked up or downloaded, and the browser's console collected.
"""

from __future__ import annotations

import shutil
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

CHROMIUM, DRIVER = "chromium", "chromedriver"


def missing() -> str | None:
    """What is missing to drive the browser, in words, or None."""
    for program, package in ((CHROMIUM, "chromium"), (DRIVER, "chromium-driver")):
        if shutil.which(program) is None:
            return (f"{program} is not installed: run make test (it installs Debian's "
                    f"{package}) or apt-get install {package}")
    return None


@contextmanager
def headless_chromium(profile: Path, *, width: int = 1300, height: int = 1000) -> Iterator[Any]:
    """A Selenium driver of a headless Chromium with its profile in ``profile``; the browser's
    console is kept (``driver.get_log("browser")``)."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    options = webdriver.ChromeOptions()
    options.binary_location = str(shutil.which(CHROMIUM))
    for argument in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                     f"--window-size={width},{height}", f"--user-data-dir={profile}",
                     "--no-first-run", "--disable-extensions", "--hide-scrollbars"):
        options.add_argument(argument)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    driver = webdriver.Chrome(service=Service(executable_path=str(shutil.which(DRIVER))),
                              options=options)
    try:
        yield driver
    finally:
        driver.quit()


def console_errors(driver: Any) -> list[str]:
    """The console's errors since the last call."""
    return [entry["message"] for entry in driver.get_log("browser")
            if entry.get("level") == "SEVERE"]
