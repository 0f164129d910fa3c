"""Debian's Chromium, headless, through Selenium: the browser of the tests
that look at pages (the report, the operator console).

    driver = headless_chromium.start()   # None: print why, exit 77 (skipped)
"""
import os
import shutil


def start(window="1200,900", extra=()):
    """A Selenium Chrome driver on the system chromium, or None (after
    saying what to install) when python3-selenium or chromedriver is missing."""
    try:
        from selenium import webdriver
        from selenium.webdriver.chrome.service import Service
    except ImportError:
        print("skip: python3-selenium is not installed (apt-get install python3-selenium)")
        return None
    driver_path = shutil.which("chromedriver") or "/usr/bin/chromedriver"
    if not os.access(driver_path, os.X_OK):
        print("skip: chromedriver is not installed (apt-get install chromium chromium-driver)")
        return None
    options = webdriver.ChromeOptions()
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                f"--window-size={window}", *extra):
        options.add_argument(arg)
    # The page's console messages (driver.get_log("browser")): a test can
    # see what the browser refused, such as a Content-Security-Policy violation.
    options.set_capability("goog:loggingPrefs", {"browser": "ALL"})
    return webdriver.Chrome(service=Service(driver_path), options=options)
