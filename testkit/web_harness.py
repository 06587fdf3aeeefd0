"""Shared pieces of the bench-page tools: headless Chromium, the page server as a process.

Debian's `chromium` and `chromium-driver` (Selenium drives them; Selenium Manager is never
asked to download anything). Used by `tools/web_screenshots.py` and `tools/bench_web.py`.
"""

from __future__ import annotations

import http.client
import os
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

from testkit.repo import REPO

CHROMIUM_FLAGS = ("--headless", "--no-sandbox", "--disable-gpu", "--disable-quic", "--no-first-run",
                  "--disable-background-networking", "--disable-component-update", "--disable-sync",
                  "--disable-dev-shm-usage", "--hide-scrollbars")


def chromium_paths() -> tuple[str | None, str | None]:
    def find(name: str) -> str | None:
        return shutil.which(name) or (f"/usr/bin/{name}" if os.path.exists(f"/usr/bin/{name}") else None)

    return find("chromium"), find("chromedriver")


def chromium_driver(profile_dir: Path, width: int = 1280, height: int = 1000) -> Any:
    """Selenium on headless Chromium with a fresh profile; exits the tool if not installed."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    browser, driver = chromium_paths()
    if browser is None or driver is None:
        raise SystemExit("headless Chromium not installed: apt-get install chromium chromium-driver "
                         "(or `make browser`)")
    options = webdriver.ChromeOptions()
    options.binary_location = browser
    for flag in (*CHROMIUM_FLAGS, f"--window-size={width},{height}", f"--user-data-dir={profile_dir}"):
        options.add_argument(flag)
    return webdriver.Chrome(service=Service(executable_path=driver), options=options)


class PageProcess:
    """`python -m daq.web` in a child process (so its CPU time can be measured alone)."""

    def __init__(self, http_port: int, bus_args: list[str], runs_dir: Path, log: Path) -> None:
        self.port = http_port
        self.log = log.open("wb")
        self.proc = subprocess.Popen([sys.executable, "-m", "daq.web", "--port", str(http_port),
                                      "--runs-dir", str(runs_dir), *bus_args], cwd=REPO,
                                     stdout=self.log, stderr=subprocess.STDOUT)

    @property
    def url(self) -> str:
        return f"http://127.0.0.1:{self.port}"

    def ready(self) -> bool:
        if self.proc.poll() is not None:
            raise SystemExit(f"the page server exited with {self.proc.returncode}; see {self.log.name}")
        try:
            conn = http.client.HTTPConnection("127.0.0.1", self.port, timeout=1)
            conn.request("GET", "/api/stats")
            ok = conn.getresponse().status == 200
            conn.close()
            return ok
        except OSError:
            return False

    def stop(self) -> None:
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait(5)
        self.log.close()


def cpu_seconds(pid: int) -> float:
    """utime + stime of a process (Linux /proc), seconds."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
