"""Screenshots of the bench page during a run and after its fit, into a folder you name.

Starts a simulated bench (`daq run` on `sim://`, 1 kHz, two encoders, real time), an
`ident worker` and the page server (`python -m daq.web`), opens the page in headless
Chromium and saves:

    1-armed.png        the page before the release (live trace, armed)
    2-during-run.png   about 1.5 s after the release (state RELEASED, the carts ringing)
    3-settled.png      when the detector says settled (run in the list, fit pending)
    4-after-fit.png    when the run's fit report is in the list
    5-paused-cursor.png  paused, the cursor on the ringing (read-out under the plot)
    6-phone.png        the same page at phone width (390 x 844)
    7-stale.png        after the daq was killed (SIGKILL): the state box and badge stale
    8-run-view.png     the run view of the fitted run (full page height)

    .venv/bin/python tools/web_screenshots.py OUT_DIR [--case both] [--rate-hz 1000]

The screenshots are not committed; look at them to check the page.
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path
from typing import Any

from selenium.webdriver.common.action_chains import ActionChains

from testkit.benchkit import Bench, sim_url
from testkit.ports import endpoint, free_port
from testkit.waiting import wait_until
from testkit.web_harness import PageProcess, chromium_driver

BENCH = "bench1"


def js(driver: Any, expr: str) -> Any:
    return driver.execute_script(f"return {expr};")


def shoot(driver: Any, out: Path, name: str) -> None:
    path = out / name
    driver.save_screenshot(str(path))
    print(f"saved {path}", flush=True)


def run(out: Path, case: str, rate_hz: float, timeout_s: float, worker: bool) -> int:
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="cartlab-shots-") as tmp:
        work = Path(tmp)
        runs = work / "runs"
        runs.mkdir()
        page_ep = endpoint()
        with Bench(work) as bench:
            page = PageProcess(free_port(), ["--listen", page_ep, "--connect", bench.endpoint], runs,
                               work / "page.log")
            driver = None
            try:
                wait_until(page.ready, 20, "the page server")
                if worker:
                    bench.start_worker("w1", runs, extra=["--connect", page_ep])
                url = sim_url([case], rate_hz=rate_hz, realtime=True, rest_s=2, pull_s=1.0,
                              hold_s=2.0, tail_s=600)
                daq = bench.start_daq("daq", url, BENCH, runs, extra=["--connect", page_ep])
                driver = chromium_driver(work / "profile", 1280, 1040)
                driver.get(page.url + "/")
                wait_until(lambda: js(driver, "window.cartlab.state") == "armed", timeout_s, "armed")
                wait_until(lambda: js(driver, "window.cartlab.pointsDrawn") > 2000, timeout_s, "a trace")
                shoot(driver, out, "1-armed.png")
                wait_until(lambda: "released" in js(driver, "window.cartlab.stateHistory"), timeout_s,
                           "the release")
                t_release = js(driver, "window.cartlab.lastT")
                wait_until(lambda: js(driver, "window.cartlab.lastT") > t_release + 1.5, 10, "1.5 s of run")
                shoot(driver, out, "2-during-run.png")
                wait_until(lambda: "settled" in js(driver, "window.cartlab.stateHistory"), timeout_s,
                           "the run to settle")
                wait_until(lambda: js(driver, "Object.keys(window.cartlab.runs).length") > 0, 10, "the run row")
                shoot(driver, out, "3-settled.png")
                if worker:
                    wait_until(lambda: js(driver, "Object.values(window.cartlab.runs).some(r => r.fit && "
                                          "(r.fit.status === 'ok' || r.fit.status === 'failed'))"),
                               timeout_s, "the fit report")
                    shoot(driver, out, "4-after-fit.png")
                    driver.find_element("css selector", "#runs-body tr[data-run] td").click()
                    wait_until(lambda: driver.find_element("id", "run-view").is_displayed(), 10, "the run view")
                    driver.set_window_size(1280, 2000)
                    shoot(driver, out, "8-run-view.png")
                    driver.set_window_size(1280, 1040)
                driver.find_element("id", "pause-btn").click()
                canvas = driver.find_element("id", "plot")
                ActionChains(driver).move_to_element_with_offset(canvas, canvas.size["width"] // 4, 0).perform()
                wait_until(lambda: js(driver, "window.cartlab.cursor"), 5, "the cursor")
                shoot(driver, out, "5-paused-cursor.png")
                driver.find_element("id", "pause-btn").click()
                driver.set_window_size(390, 844)
                shoot(driver, out, "6-phone.png")
                driver.set_window_size(1280, 1040)
                daq.kill9()
                wait_until(lambda: js(driver, "window.cartlab.stale"), 20, "the page to turn stale")
                shoot(driver, out, "7-stale.png")
                print(f"rates seen by the page: {js(driver, 'JSON.stringify(window.cartlab.rates)')}")
            finally:
                if driver is not None:
                    driver.quit()
                page.stop()
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("out", type=Path, help="folder for the PNG files (created)")
    parser.add_argument("--case", choices=["cart1", "cart2", "both"], default="both")
    parser.add_argument("--rate-hz", type=float, default=1000.0)
    parser.add_argument("--timeout-s", type=float, default=120.0, help="longest wait for each step")
    parser.add_argument("--no-worker", action="store_true", help="no ident worker (no fit screenshot)")
    args = parser.parse_args(argv)
    return run(args.out, args.case, args.rate_hz, args.timeout_s, not args.no_worker)


if __name__ == "__main__":
    raise SystemExit(main())
