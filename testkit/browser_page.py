"""The bench page in headless Chromium, for the browser tests (`tests/daq/test_web_browser*.py`).

`NEEDS_CHROMIUM` skips a module, with the reason, when `chromium` or `chromedriver` is not
installed (`make browser` installs them). `open_page` opens the page in a fresh profile and
records the state badge's texts (`window.badgeTexts`); the other helpers read the page's DOM
and its `window.cartlab` state in one script call each (the runs table is re-rendered).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

import pytest
import zenoh

from testkit.web_support import PageServer, chromium_driver, chromium_paths

BROWSER, DRIVER = chromium_paths()
NEEDS_CHROMIUM = pytest.mark.skipif(
    BROWSER is None or DRIVER is None,
    reason="headless Chromium not installed (Debian packages chromium and chromium-driver; `make browser` "
           "installs them): browser tests skipped")


@contextmanager
def open_page(page: PageServer, profile: str, url_suffix: str = "/") -> Iterator[Any]:
    """The page open in Chromium (profile directory `profile`), recording its state badge's texts."""
    driver = chromium_driver(profile)
    try:
        driver.set_page_load_timeout(20)
        driver.get(page.url + url_suffix)
        driver.execute_script("""
            window.badgeTexts = [document.getElementById('state-text').textContent];
            new MutationObserver(() => window.badgeTexts.push(document.getElementById('state-text').textContent))
              .observe(document.getElementById('state-text'),
                       {childList: true, characterData: true, subtree: true});""")
        yield driver
    finally:
        driver.quit()


def js(browser: Any, expr: str) -> Any:
    return browser.execute_script(f"return {expr};")


def query(session: zenoh.Session, key: str) -> bytes:
    for reply in session.get(key, timeout=5.0):
        if reply.ok is not None:
            return bytes(reply.ok.payload.to_bytes())
    raise AssertionError(f"no reply on {key}")


def run_ids(browser: Any) -> list[str]:
    return list(js(browser, "[...document.querySelectorAll('#runs-body tr[data-run]')].map(r => r.dataset.run)"))


def row_cells(browser: Any, run_id: str) -> list[str]:
    """The text of each cell of a run's row, read in one go (the table is re-rendered)."""
    return list(browser.execute_script(
        "const r = document.querySelector(`#runs-body tr[data-run=\"${arguments[0]}\"]`);"
        "return r ? [...r.cells].map(c => c.innerText.trim()) : [];", run_id))


def row_links(browser: Any, run_id: str) -> dict[str, str]:
    return dict(browser.execute_script(
        "const r = document.querySelector(`#runs-body tr[data-run=\"${arguments[0]}\"]`);"
        "return r ? [...r.querySelectorAll('td.files a')].map(a => [a.textContent, a.href]) : [];", run_id))


def blue_pixels(browser: Any) -> int:
    """Pixels of the canvas drawn in cart 1's colour (#1f5fbf)."""
    return int(browser.execute_script("""
        const c = document.getElementById('plot'), d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;
        let n = 0;
        for (let i = 0; i < d.length; i += 4)
          if (Math.abs(d[i] - 31) < 40 && Math.abs(d[i + 1] - 95) < 40 && Math.abs(d[i + 2] - 191) < 40) n++;
        return n;"""))


def canvas_png(browser: Any) -> str:
    return str(js(browser, "document.getElementById('plot').toDataURL()"))


def fits_in(browser: Any, width: int) -> bool:
    return bool(js(browser, "window.innerWidth") <= width)


def overflow_px(browser: Any) -> int:
    return int(js(browser, "document.documentElement.scrollWidth - document.documentElement.clientWidth"))


__all__ = ["BROWSER", "DRIVER", "NEEDS_CHROMIUM", "blue_pixels", "canvas_png", "fits_in", "js", "open_page",
           "overflow_px", "query", "row_cells", "row_links", "run_ids"]
