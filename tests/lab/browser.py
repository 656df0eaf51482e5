"""Headless Chromium from Debian (/usr/bin/chromium, /usr/bin/chromedriver) driven by selenium; never a
downloaded browser. Screenshots go to $RIG_TEST_ARTIFACTS (default: a folder under the system temp)."""

from __future__ import annotations

import os
import shutil
import tempfile
from pathlib import Path

from selenium.common.exceptions import WebDriverException
from selenium.webdriver.support.ui import WebDriverWait

CHROMIUM = os.environ.get("RIG_CHROMIUM", "/usr/bin/chromium")
CHROMEDRIVER = os.environ.get("RIG_CHROMEDRIVER", "/usr/bin/chromedriver")
FLAGS = ["--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
         "--disable-background-networking", "--disable-component-update", "--disable-sync",
         "--disable-dev-shm-usage", "--window-size=1400,1000"]


def artifacts_dir() -> Path:
    folder = Path(os.environ.get("RIG_TEST_ARTIFACTS") or Path(tempfile.gettempdir()) / "rig-test-artifacts")
    folder.mkdir(parents=True, exist_ok=True)
    return folder


def start_browser():
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    for path in (CHROMIUM, CHROMEDRIVER):
        if not Path(path).exists():
            raise RuntimeError(f"{path} is missing: scripts/test.sh installs Debian's chromium and chromium-driver")
    profile = tempfile.mkdtemp(prefix="rig-chromium-")
    options = webdriver.ChromeOptions()
    options.binary_location = CHROMIUM
    for flag in FLAGS + [f"--user-data-dir={profile}"]:
        options.add_argument(flag)
    driver = webdriver.Chrome(service=Service(executable_path=CHROMEDRIVER), options=options)
    driver.set_page_load_timeout(30)
    driver.rig_profile = profile
    return driver


def stop_browser(driver) -> None:
    profile = getattr(driver, "rig_profile", None)
    try:
        driver.quit()
    finally:
        if profile:
            shutil.rmtree(profile, ignore_errors=True)


def screenshot(driver, name: str) -> Path:
    path = artifacts_dir() / f"{name}.png"
    driver.save_screenshot(str(path))
    print(f"screenshot: {path}")
    return path


def navigate(browser, element) -> None:
    """Click what leads to another page and wait until that page has replaced this one and loaded.

    The old page is marked in its window rather than watched through a node: asked about a node of a page
    being replaced, Chromium sometimes answers with an inspector error instead of "stale" (failed CI once)."""
    browser.execute_script("window.__leaving = true")
    element.click()
    WebDriverWait(browser, 15, ignored_exceptions=(WebDriverException,)).until(
        lambda b: b.execute_script("return window.__leaving === undefined && document.readyState === 'complete'"))
