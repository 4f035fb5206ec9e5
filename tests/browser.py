"""Headless Chromium for the browser tests (the docs site, the chart explorer).

Debian's ``chromium`` and ``chromium-driver`` are driven through selenium, with the driver
and the browser named by path (selenium never looks for or downloads either) and the
browser started with no network activity of its own and a fresh profile. Without Chromium a
browser test is skipped on a developer's machine, and fails under CI (``CI=true``), where
``.ci/run`` installs it.
"""

from __future__ import annotations

import os
import shutil
import tempfile
from collections.abc import Iterator
from pathlib import Path

import pytest

CHROMIUM_FLAGS = ("--headless", "--no-sandbox", "--disable-gpu",
                  "--disable-background-networking", "--disable-component-update",
                  "--disable-sync", "--no-first-run", "--disable-dev-shm-usage",
                  "--window-size=1280,900")


def in_ci() -> bool:
    return os.environ.get("CI", "").lower() in ("1", "true", "yes")


def chromium_paths() -> tuple[str, str] | None:
    """(browser, driver) paths, or None when either is missing."""
    browser = shutil.which("chromium") or shutil.which("chromium-browser")
    driver = shutil.which("chromedriver") or (
        "/usr/bin/chromedriver" if Path("/usr/bin/chromedriver").exists() else None)
    return (browser, driver) if browser and driver else None


def require_chromium() -> tuple[str, str]:
    """The paths, or skip (a developer's machine) / fail (CI) saying how to install it."""
    paths = chromium_paths()
    if paths is None:
        message = ("Chromium is missing: apt-get install -y --no-install-recommends "
                   "chromium chromium-driver")
        if in_ci():
            pytest.fail(message + " (.ci/run installs it under CI)")
        pytest.skip(message)
    return paths


def start_chromium() -> Iterator:
    """A selenium Chrome driver on Debian's Chromium; quits it and removes its profile."""
    browser, driver_path = require_chromium()
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    profile = tempfile.mkdtemp(prefix="bearingdyn-chromium-")
    options = webdriver.ChromeOptions()
    options.binary_location = browser
    for flag in (*CHROMIUM_FLAGS, f"--user-data-dir={profile}"):
        options.add_argument(flag)
    options.add_argument("--allow-file-access-from-files")
    driver = webdriver.Chrome(service=Service(executable_path=driver_path), options=options)
    driver.set_page_load_timeout(60)
    try:
        yield driver
    finally:
        driver.quit()
        shutil.rmtree(profile, ignore_errors=True)
