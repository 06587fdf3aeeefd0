"""The bench page refuses a foreign Host in a real browser (issue 14 row 9: DNS rebinding).

A name resolved to 127.0.0.1 by Chromium's resolver rules (what DNS rebinding does) gets
neither the page nor its buttons; the right name still does. No daq is needed: the page
server alone, on an empty runs directory.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from daq.web.service import WebSettings
from schemas.bus import BusConfig
from testkit import ports
from testkit.browser_page import NEEDS_CHROMIUM
from testkit.web_support import PageServer, chromium_driver

pytestmark = [NEEDS_CHROMIUM, pytest.mark.timeout(90)]


@pytest.fixture
def page(tmp_path: Path) -> Iterator[Any]:
    settings = WebSettings(bus=BusConfig(listen=[ports.endpoint()], connect=[]), runs_dir=tmp_path / "runs",
                           status_every_s=0.5, query_timeout_s=2.0)
    with PageServer(settings) as server:
        yield server


def test_a_dns_rebinding_page_is_refused(page: PageServer, tmp_path: Path) -> None:
    """A foreign name resolved to 127.0.0.1 (what DNS rebinding does) gets neither the page nor
    the buttons: the server refuses its Host, the browser's own same-origin fetch included."""
    rules = "--host-resolver-rules=MAP rebind.example 127.0.0.1"
    driver = chromium_driver(str(tmp_path / "chromium-rebind"), (rules,))
    try:
        driver.set_page_load_timeout(20)
        driver.get(f"http://rebind.example:{page.port}/")
        assert "expected one of" in driver.find_element("tag name", "body").text
        assert not driver.find_elements("id", "plot")
        result = driver.execute_async_script("""
            const done = arguments[arguments.length - 1];
            const post = (p) => fetch(p, {method: 'POST', headers: {'X-Cartlab-Action': '1'}}).then(r => r.status);
            Promise.all([post('/api/bench/benchA/zero'), post('/api/bench/benchA/arm'),
                         fetch('/api/snapshot').then(r => r.status), fetch('/files/x/mcap').then(r => r.status)])
              .then(done, (e) => done(String(e)));""")
        assert result == [403, 403, 403, 403]
        driver.get(f"http://127.0.0.1:{page.port}/")                 # the right name still works
        assert driver.find_elements("id", "plot")
    finally:
        driver.quit()
