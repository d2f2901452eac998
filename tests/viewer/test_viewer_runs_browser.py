"""The live page in a real browser (Debian's chromium) lists the runs of its store and lays a finished run's curves
over the running one's; its header shows how far the run is and how long it has left. A real `racer train` runs
beside a finished short run in the same store (tests/conftest.py's `two_short_runs`, which the compare tests read
too: trained once). The test leaves a screenshot at .pytest_cache/d/viewer/runs.png."""

from __future__ import annotations

import json
import re
import shutil
import signal
import subprocess
import time
import urllib.request

import pytest

from tests.browser import click, text_of, wait_for
from tests.conftest import write_custom_files
from tests.short_runs import CENTRE, train_args, train_env
from tests.viewer.conftest import free_port

pytestmark = [pytest.mark.slow, pytest.mark.heavy]  # a training run, a browser, the two_short_runs

FINISHED = CENTRE
"""The shared runs' 6-episode run."""
LIVE = "live-run"

OVERLAY_REWARDS = """const chart = window.racerViewer.charts.reward;
const set = chart.data.datasets.find(d => d.label === arguments[0]);
return set ? [set.data.filter(v => v !== null), set.borderDash] : null;"""
RUN_ROW = """const row = document.querySelector(`#runs tr[data-run="${arguments[0]}"]`);
return row ? [[...row.querySelectorAll("td")].map(td => td.textContent), row.className] : null;"""
"""A run's row as its cells' texts and its class, read in one call: the page rebuilds the rows as the live run goes."""


def test_the_live_page_overlays_a_finished_run_of_its_store(two_short_runs, tmp_path, browser, request):
    finished = two_short_runs[1]
    store = finished.parent
    custom_files = write_custom_files(tmp_path / "custom_files")
    logged = [json.loads(line) for line in (finished / "metrics" / "iterations.jsonl").read_text().splitlines()]

    port = free_port()
    train = subprocess.Popen(
        train_args(custom_files, LIVE, "--max-minutes", "3", "--viewer-port", str(port)),
        stdout=subprocess.PIPE,
        stderr=subprocess.STDOUT,
        text=True,
        env=train_env(store),
        cwd=tmp_path,
    )
    url = f"http://127.0.0.1:{port}/"

    def describe() -> str:
        log = store / ".runs" / LIVE / "viewer.log"
        return log.read_text(errors="replace")[-1500:] if log.exists() else "no viewer log"

    def page_answers() -> bool:
        try:
            return urllib.request.urlopen(url, timeout=2).status == 200
        except OSError:
            return False

    try:
        wait_for("the viewer to answer", page_answers, 120, describe)
        browser.get(url)
        row = lambda name: browser.execute_script(RUN_ROW, name)  # noqa: E731
        wait_for("the finished run in the list", lambda: row(FINISHED), 60, describe)
        wait_for("the live run in the list", lambda: row(LIVE), 60, describe)
        (cells, _), (live_cells, live_class) = row(FINISHED), row(LIVE)
        assert cells[2] == "finished" and cells[3] == str(len(logged)), cells
        assert cells[6] == f"{logged[-1]['progress']['episodes']}/6 episodes", cells
        assert live_cells[1] == "shown" and "current" in live_class.split(), (live_cells, live_class)

        # Ticked: its curves lie over the live run's, dashed, with its logged rewards.
        checkbox = f'#runs input[type=checkbox][data-run="{FINISHED}"]'
        click(browser, checkbox)
        curves = lambda: browser.find_element("id", "curves").get_attribute("data-overlays")  # noqa: E731
        wait_for("the overlay", lambda: curves() == FINISHED, 30, describe)
        rewards, dash = browser.execute_script(OVERLAY_REWARDS, FINISHED)
        assert rewards == pytest.approx([r["mean_reward"] for r in logged]) and dash
        labels = browser.execute_script("return window.racerViewer.charts.progress.data.labels")
        assert labels[: len(logged)] == [r["iteration"] for r in logged]

        # The live run's first iteration: the header says how far it is of its 3 minutes and what is left.
        points = lambda: int(browser.find_element("id", "curves").get_attribute("data-points"))  # noqa: E731
        wait_for("the live run's first iteration", points, 240, describe)
        eta = wait_for("the time left", lambda: text_of(browser, "eta"), 30, describe)
        assert re.fullmatch(r"\d+:\d\d of 3:00 · (about \d+:\d\d left|stopping)", eta), eta
        first = eta
        time.sleep(2.5)
        assert text_of(browser, "eta") != first  # it counts on between iterations

        browser.execute_script("window.scrollTo(0, 0)")
        time.sleep(1.0)
        screenshot = tmp_path / "runs.png"
        assert browser.save_screenshot(str(screenshot)) and screenshot.stat().st_size > 20_000
        kept = request.config.cache.mkdir("viewer") / "runs.png"
        shutil.copyfile(screenshot, kept)
        print(f"screenshot kept at {kept}")

        # Unticked: the overlay is gone.
        click(browser, checkbox)
        wait_for("the overlay removed", lambda: curves() == "", 30, describe)
        assert browser.execute_script(OVERLAY_REWARDS, FINISHED) is None
    finally:
        if train.poll() is None:
            train.send_signal(signal.SIGINT)
        try:
            output, _ = train.communicate(timeout=180)
        except subprocess.TimeoutExpired:
            train.kill()
            output, _ = train.communicate()
    assert train.returncode == 0, output[-3000:]
    assert re.search(r"iteration +0 .*\| \d+:\d\d of 3:00, (about \d+:\d\d left|stopping)", output), output[-3000:]
