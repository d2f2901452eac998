"""What `python -m benchmarks viewer` switches on beside a training, and the CPU it counts: the live page in a headless
Chromium (`HeadlessBrowser`), the frame tap alone (`WatchingOnly`: the `watching` key, nothing polls), the page's
HTTP polls from a Python thread (`PagePolls`), and the CPU seconds of a process tree and of the whole machine."""

from __future__ import annotations

import json
import os
import threading
import time
import urllib.request
from pathlib import Path

import click

from racer.shared.transport.frames import FrameChannel

CHROMIUM = "/usr/bin/chromium"
CHROMEDRIVER = "/usr/bin/chromedriver"


def tree_cpu_s(root_pid: int) -> float:
    """User + system CPU seconds of a process and its live descendants (Chromium's renderer and GPU processes)."""
    ticks = os.sysconf("SC_CLK_TCK")
    parents: dict[int, int] = {}
    times: dict[int, float] = {}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            fields = (entry / "stat").read_text().rsplit(")", 1)[1].split()
        except (FileNotFoundError, ProcessLookupError):
            continue
        parents[int(entry.name)] = int(fields[1])
        times[int(entry.name)] = (int(fields[11]) + int(fields[12])) / ticks
    total = 0.0
    for pid, cpu_s in times.items():
        ancestor = pid
        while ancestor > 1 and ancestor != root_pid:
            ancestor = parents.get(ancestor, 1)
        if ancestor == root_pid:
            total += cpu_s
    return total


def machine_busy_s() -> float:
    """CPU seconds the whole machine has spent busy (all cores, every process) since boot, from /proc/stat."""
    fields = [int(v) for v in Path("/proc/stat").read_text().split("\n", 1)[0].split()[1:]]
    idle = fields[3] + (fields[4] if len(fields) > 4 else 0)
    return (sum(fields[:8]) - idle) / os.sysconf("SC_CLK_TCK")


class HeadlessBrowser:
    """One headless Chromium (Debian's, driven by selenium) kept open for the whole run. `load()` opens the viewer
    page once; `start()` and `stop()` wake and freeze it (the DevTools protocol's page lifecycle: a frozen page runs
    no timer and draws nothing), so the measured cost is the open page's, without loading it again each time."""

    def __init__(self, url: str):
        try:
            from selenium import webdriver
            from selenium.webdriver.chrome.service import Service
        except ImportError as error:
            raise click.ClickException("selenium is needed: pip install -e '.[test]'") from error
        options = webdriver.ChromeOptions()
        options.binary_location = CHROMIUM
        for argument in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage", "--window-size=1500,1900"):
            options.add_argument(argument)
        self.url = url
        self.service = Service(executable_path=CHROMEDRIVER)  # explicit: selenium-manager never runs
        self.driver = webdriver.Chrome(service=self.service, options=options)
        self.driver.get("about:blank")

    def cpu_s(self) -> float:
        return tree_cpu_s(self.service.process.pid)

    def load(self) -> None:
        self.driver.get(self.url)

    def start(self) -> None:
        self.driver.execute_cdp_cmd("Page.setWebLifecycleState", {"state": "active"})

    def stop(self) -> None:
        self.driver.execute_cdp_cmd("Page.setWebLifecycleState", {"state": "frozen"})

    def quit(self) -> None:
        self.driver.quit()


class WatchingOnly:
    """Only the `watching` key, renewed as the page would: the workers' frame tap runs, nothing reads the frames."""

    def __init__(self, frames: FrameChannel):
        self.frames = frames
        self._on = threading.Event()
        self._quit = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._quit.wait(1.0):
            if self._on.is_set():
                self.frames.mark_watching()

    def cpu_s(self) -> float:
        return 0.0

    def load(self) -> None:
        pass

    def start(self) -> None:
        self.frames.mark_watching()
        self._on.set()

    def stop(self) -> None:
        self._on.clear()

    def quit(self) -> None:
        self._quit.set()
        self._thread.join(5)


class PagePolls:
    """The page's requests without a browser (a Python thread): the live endpoint twice a second, every new camera
    frame, the progress endpoint every 3 s, the store's run list every 15 s; the viewer server, Redis and the tap
    work as with the page."""

    def __init__(self, url: str):
        self.url = url.rstrip("/")
        self._on = threading.Event()
        self._quit = threading.Event()
        self._cpu_s = 0.0
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _get(self, path: str) -> bytes:
        with urllib.request.urlopen(self.url + path, timeout=5) as response:
            return response.read()

    def _run(self) -> None:
        seen: dict[int, str] = {}
        next_progress = next_runs = 0.0
        while not self._quit.wait(0.5):
            if not self._on.is_set():
                continue
            started = time.thread_time()
            try:
                for worker in json.loads(self._get("/api/live?watch=1")).get("workers", []):
                    frame = worker.get("frame")
                    if frame and frame["has_image"] and seen.get(worker["id"]) != frame["id"]:
                        seen[worker["id"]] = frame["id"]
                        self._get(f"/api/workers/{worker['id']}/frame.jpg")
                if time.monotonic() >= next_progress:
                    next_progress = time.monotonic() + 3.0
                    self._get("/api/progress")
                if time.monotonic() >= next_runs:
                    next_runs = time.monotonic() + 15.0
                    self._get("/api/runs")
            except OSError as error:
                click.echo(f"poll failed: {error}", err=True)
            self._cpu_s += time.thread_time() - started

    def cpu_s(self) -> float:
        return self._cpu_s

    def load(self) -> None:
        pass

    def start(self) -> None:
        self._on.set()

    def stop(self) -> None:
        self._on.clear()

    def quit(self) -> None:
        self._quit.set()
        self._thread.join(10)
