"""Headless Chromium (the Debian package) driven by Playwright, for the report/viewer tests.

No browser is downloaded: Playwright launches the system's Chromium through its
executable path (``POLYPACK_CHROMIUM`` or ``chromium`` / ``chromium-browser`` on PATH).
A missing browser or Playwright FAILS the tests in CI (``CI`` set to a true value, as CI
services do; .ci/run installs Chromium); outside CI (``CI`` unset) the tests are skipped
and the session ends with one line saying how to run them (tests/conftest.py).
``POLYPACK_SKIP_BROWSER_TESTS=1`` skips them on purpose anywhere.
"""

from __future__ import annotations

import os
import shutil

import numpy as np
import pytest

ARGS = ["--no-sandbox", "--use-angle=swiftshader", "--enable-unsafe-swiftshader", "--ignore-gpu-blocklist",
        "--disable-gpu-sandbox", "--disable-dev-shm-usage"]


def chromium_path():
    env = os.environ.get("POLYPACK_CHROMIUM")
    if env:
        return env
    for name in ("chromium", "chromium-browser", "google-chrome", "google-chrome-stable"):
        p = shutil.which(name)
        if p:
            return p
    return None


#: Why browser tests were skipped outside CI (reported once at the end of the session).
MISSING = []
HOW = "apt-get install chromium; pip install playwright (or POLYPACK_CHROMIUM=/path/to/chromium)"


def in_ci() -> bool:
    """``CI`` set to a true value (GitHub Actions, GitLab and most services set ``CI=true``)."""
    return os.environ.get("CI", "").strip().lower() not in ("", "0", "false", "no", "off")


def _missing(what):
    if os.environ.get("POLYPACK_SKIP_BROWSER_TESTS") == "1":
        pytest.skip(f"{what} (POLYPACK_SKIP_BROWSER_TESTS=1)")
    if in_ci():
        pytest.fail(f"{what}: the browser tests need it in CI ({HOW}), "
                    "or set POLYPACK_SKIP_BROWSER_TESTS=1 to skip them on purpose")
    MISSING.append(what)
    pytest.skip(f"{what}: browser tests skipped outside CI; to run them: {HOW}")


def launch(playwright_cm):
    """A headless Chromium browser of the system."""
    exe = chromium_path()
    if exe is None:
        _missing("no Chromium executable found")
    return playwright_cm.chromium.launch(executable_path=exe, headless=True, args=ARGS)


def sync_playwright():
    try:
        from playwright.sync_api import sync_playwright as sp
    except ImportError:
        _missing("the playwright Python package is not installed")
    return sp()


def _driver_notice(text):
    """Chromium's own GL driver performance notices (software rendering under load, e.g. "GPU
    stall due to ReadPixels" when the PNG export reads the canvas back): not errors of the page."""
    return "GL Driver Message" in text and "Performance" in text


class Page:
    """A page with its console errors, page errors and every request it made."""

    def __init__(self, browser, width=900, height=700):
        self.page = browser.new_page(viewport={"width": width, "height": height})
        self.errors, self.requests = [], []
        self.page.on("console", lambda m: self.errors.append(f"console.{m.type}: {m.text}")
                     if m.type in ("error", "warning") and not _driver_notice(m.text) else None)
        self.page.on("pageerror", lambda e: self.errors.append(f"pageerror: {e}"))
        self.page.on("request", lambda r: self.requests.append(r.url))
        self.page.on("requestfailed", lambda r: self.errors.append(f"request failed: {r.url}"))

    def open(self, path, timeout=60000):
        self.url = path.resolve().as_uri()
        self.page.goto(self.url)
        self.wait_frames(1, timeout)
        return self

    def wait_frames(self, k, timeout=60000, index=-1):
        self.page.wait_for_function(
            f"() => {{ const v = (window.polypackViewers || []).at({index}); return v && v.frames >= {k}; }}",
            timeout=timeout)

    def viewer(self, expr, index=-1):
        return self.page.evaluate(f"() => {{ const v = window.polypackViewers.at({index}); return {expr}; }}")

    def redraw(self, index=-1):
        """Draw now and wait until the frame is finished (readPixels)."""
        self.page.evaluate(f"""() => {{ const v = window.polypackViewers.at({index}); v.draw();
            const px = new Uint8Array(4); v.gl.readPixels(0, 0, 1, 1, v.gl.RGBA, v.gl.UNSIGNED_BYTE, px); }}""")

    def canvas_pixels(self, index=-1):
        """RGB pixels of the viewer's canvas (its drawing buffer, through toDataURL)."""
        import base64
        from io import BytesIO

        from PIL import Image

        url = self.page.evaluate(f"() => window.polypackViewers.at({index}).canvas.toDataURL('image/png')")
        png = base64.b64decode(url.split(",", 1)[1])
        return np.asarray(Image.open(BytesIO(png)).convert("RGB"), dtype=np.float64)

    def close(self):
        self.page.close()


def foreground_fraction(px, background=(255, 255, 255)):
    """Fraction of pixels that differ from the background colour by more than 12 levels."""
    d = np.abs(px - np.asarray(background, dtype=np.float64)).max(axis=2)
    return float(np.mean(d > 12))
