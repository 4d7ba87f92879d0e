"""The system's headless Chromium driven by Selenium through the system chromedriver (Debian's
``chromium`` and ``chromium-driver``; nothing downloaded): what the viewer's tests, its latency
benchmark and the docs' screenshot open the page with."""

from __future__ import annotations

import shutil
import time
from typing import Any

#: Where Debian installs them (found on PATH first).
CHROMIUM_NAMES, DRIVER_NAMES = ("chromium", "chromium-browser"), ("chromedriver",)


def _which(names: tuple[str, ...]) -> str | None:
    return next((path for name in names if (path := shutil.which(name))), None)


def missing() -> str | None:
    """Why no headless Chromium can be driven here (None: it can)."""
    try:
        import selenium  # noqa: F401
    except ImportError:
        return "selenium is not installed (pip install selenium; the dev extra has it)"
    if _which(CHROMIUM_NAMES) is None or _which(DRIVER_NAMES) is None:
        return ("Debian's chromium and chromium-driver are not installed (scripts/setup.sh "
                "installs them where apt-get exists)")  # fmt: skip
    return None


def headless_chromium(width: int = 1300, height: int = 900) -> Any:
    """A Selenium driver of a headless Chromium window of ``width``×``height`` CSS pixels."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    problem = missing()
    if problem is not None:
        raise RuntimeError(problem)
    options = webdriver.ChromeOptions()
    options.binary_location = _which(CHROMIUM_NAMES)  # type: ignore[assignment]
    for arg in ("--headless=new", "--no-sandbox", "--disable-gpu", "--disable-dev-shm-usage",
                f"--window-size={width},{height}", "--hide-scrollbars"):  # fmt: skip
        options.add_argument(arg)
    return webdriver.Chrome(service=Service(_which(DRIVER_NAMES)), options=options)


def wait_for(driver: Any, script: str, timeout_s: float = 60.0) -> Any:
    """The value of the JavaScript expression ``script`` once it is truthy; an error naming it
    and what the page shows after ``timeout_s``."""
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        value = driver.execute_script(f"return {script};")
        if value:
            return value
        time.sleep(0.02)
    text = driver.execute_script("return document.body.innerText")[:300]
    raise AssertionError(f"the page never had {script}; it shows: {text}")


def final_after(driver: Any, count: int, timeout_s: float = 60.0) -> dict:
    """The page's next full-size frame after ``count`` of them (the one of its latest view)."""
    wait_for(driver, f"viewer.finals > {count} && viewer.lastFinal.seq == viewer.seq", timeout_s)
    return driver.execute_script("return viewer.lastFinal;")
