"""The live page in a real headless browser (Debian's chromium driven by selenium) on a running `racer train`:
frames arrive and change, the curves gain a point, a stopped worker shows as down and comes back.
The test leaves a screenshot at <store>/.runs/<model>/viewer.png, and a copy that outlives the test's temporary
folder at .pytest_cache/d/viewer/viewer.png."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
import urllib.request
from pathlib import Path

import pytest

from racer.local.services import _die_with_parent
from tests.browser import wait_for
from tests.conftest import write_custom_files
from tests.short_runs import train_args, train_env
from tests.viewer.conftest import free_port

pytestmark = [pytest.mark.slow, pytest.mark.heavy]  # a training run and a browser

MODEL = "viewer-model"

PIXEL_HASH = """
const img = document.querySelector('.worker[data-worker="0"] .incar img');
if (!img || img.hidden || !img.complete || !img.naturalWidth) return null;
const canvas = document.createElement('canvas');
canvas.width = img.naturalWidth; canvas.height = img.naturalHeight;
const context = canvas.getContext('2d');
context.drawImage(img, 0, 0);
const pixels = context.getImageData(0, 0, canvas.width, canvas.height).data;
let hash = 0;
for (let i = 0; i < pixels.length; i += 4) hash = (hash * 31 + pixels[i]) >>> 0;
return [img.dataset.frameId, hash, canvas.width, canvas.height];
"""


def test_live_page_follows_a_running_training(tmp_path, browser, request):
    custom_files = write_custom_files(tmp_path / "custom_files")
    store = tmp_path / "store"
    port = free_port()
    train = subprocess.Popen(
        train_args(custom_files, MODEL, "--max-episodes", "400", "--viewer-port", str(port)),
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env=train_env(store),
        cwd=tmp_path,
    )
    logs = store / ".runs" / MODEL
    replacement: subprocess.Popen | None = None
    url = f"http://127.0.0.1:{port}/"

    def describe() -> str:
        tails = []
        for name in ("viewer", "trainer", "worker-0", "worker-1"):
            path = logs / f"{name}.log"
            if path.exists():
                tails.append(f"--- {name}.log\n{path.read_text(errors='replace')[-1500:]}")
        try:
            live = urllib.request.urlopen(url + "api/live?watch=0", timeout=5).read().decode()[:1500]
        except OSError as error:
            live = str(error)
        return f"/api/live: {live}\n" + "\n".join(tails)

    def live_workers() -> dict[int, dict]:
        body = urllib.request.urlopen(url + "api/live?watch=0", timeout=10).read()
        return {w["id"]: w for w in json.loads(body)["workers"]}

    try:

        def page_answers() -> bool:
            try:
                return urllib.request.urlopen(url, timeout=2).status == 200
            except OSError:
                return False

        wait_for("the viewer to answer", page_answers, 120, describe)
        browser.get(url)
        assert "viewer" in browser.title
        assert wait_for("the model name", lambda: browser.find_element("id", "model").text == MODEL, 30, describe)
        assert browser.find_element("id", "mode-badge").text.lower() == "live"

        # A camera frame arrives (an image decoded by the browser), then a different one.
        first = wait_for("worker 0's first camera frame", lambda: browser.execute_script(PIXEL_HASH), 180, describe)
        assert first[2:] == [160, 120]
        second = wait_for(
            "a new, different frame",
            lambda: (
                (frame := browser.execute_script(PIXEL_HASH))
                and frame[0] != first[0]
                and frame[1] != first[1]
                and frame
            ),
            120,
            describe,
        )
        assert second[1] != first[1]
        # The car on the map: the map needs the run's params, which may come after the first frames.
        car_on_map = "const v = window.racerViewer.workers.get(0); return !!(v && v.chart && v.chart.data.datasets[4].data.length === 1);"
        assert wait_for("worker 0's car on the track map", lambda: browser.execute_script(car_on_map), 60, describe)

        # The curves gain a point after an iteration.
        points = lambda: int(browser.find_element("id", "curves").get_attribute("data-points"))  # noqa: E731
        before = wait_for("a first iteration", points, 180, describe)
        wait_for("one more iteration on the curves", lambda: points() > before, 180, describe)
        assert browser.execute_script("return window.racerViewer.charts.reward.data.labels.length") == points()
        wait_for(
            "an evaluation row",
            lambda: browser.find_elements("css selector", "#evaluations tbody tr:not(.empty)"),
            180,
            describe,
        )

        # Stop worker 1 (SIGTERM: it exits cleanly, so racer train does not restart it): the page says DOWN.
        card = lambda: browser.find_element("css selector", '.worker[data-worker="1"]')  # noqa: E731
        wait_for("worker 1 up", lambda: card().get_attribute("data-up") == "true", 60, describe)
        pid = live_workers()[1]["pid"]
        worker_env = dict(
            entry.split("=", 1)
            for entry in Path(f"/proc/{pid}/environ").read_bytes().decode().split("\0")
            if "=" in entry
        )
        os.kill(pid, signal.SIGTERM)
        wait_for("worker 1 shown as down", lambda: card().get_attribute("data-up") == "false", 90, describe)
        assert "DOWN" in card().text

        # A worker 1 started again (as compose's restart policy or a user would) shows as up again.
        replacement = subprocess.Popen(
            [sys.executable, "-m", "racer.cli", "rollout", "--model-prefix", MODEL, "--worker-id", "1", "--seed", "11"],
            stdout=open(logs / "worker-1-again.log", "ab"),
            stderr=subprocess.STDOUT,
            env=worker_env,
            preexec_fn=_die_with_parent,
        )
        wait_for("worker 1 back up", lambda: card().get_attribute("data-up") == "true", 120, describe)
        assert "DOWN" not in card().find_element("css selector", ".pill").text
        assert "restarted" in card().text

        # A last look for people: the screenshot next to the run's logs.
        browser.execute_script("window.scrollTo(0, 0)")
        time.sleep(1.5)
        screenshot = logs / "viewer.png"
        assert browser.save_screenshot(str(screenshot))
        assert screenshot.stat().st_size > 20_000
        kept = request.config.cache.mkdir("viewer") / "viewer.png"
        shutil.copyfile(screenshot, kept)
        print(f"screenshot: {screenshot}, kept at {kept}")
    finally:
        if train.poll() is None:
            train.send_signal(signal.SIGINT)
        try:
            output, _ = train.communicate(timeout=180)
        except subprocess.TimeoutExpired:
            train.kill()
            output, _ = train.communicate()
        if replacement is not None:
            replacement.terminate()
            replacement.wait(30)
    assert train.returncode == 0, output[-3000:]
    assert "watch it live at http://localhost:" in output
