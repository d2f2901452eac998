"""`racer bench viewer`: how much one open viewer page slows the experience rate of a training.

A real `racer train` run (4 workers by default, the live page on a loopback port) alternates iteration by
iteration between no page and one page open in a headless Chromium (Debian's `chromium`, kept running for the
whole run and switched between the page and about:blank by selenium): the workers publish
frames only in the second case, the viewer server answers the page's polls, the browser draws. Each iteration's
experience rate (steps played / rollout wall time, from the trainer's iteration records) is compared with the
mean of its neighbours under the other condition, so the learning trend (longer episodes, more steps/s) and the
load of other processes cancel out as far as they can. Before the training starts, the frame tap is also timed
alone in this process (per step unwatched, per published frame watched), which a busy machine disturbs less.
Prints one JSON line; progress on stderr.
"""

from __future__ import annotations

import json
import os
import signal
import socket
import statistics
import tempfile
import time
from pathlib import Path

import click
import numpy as np

from racer.shared.config import LocalStoreSettings, RedisSettings, ServiceSettings
from racer.shared.redis_connection import RedisLink
from racer.shared.services import PROJECT_ROOT
from racer.shared.sim.config import EnvConfig
from racer.shared.sim.env import DeepRacerEnv
from racer.shared.sim.worlds import WORLD_NAMES as WORLDS
from racer.shared.transport.channels import RunChannel
from racer.shared.transport.frames import FrameChannel, FrameSettings, FrameTap

CENTRE_LINE_REWARD = PROJECT_ROOT.parent / "shared/deepracer-data/reward_functions/awsdoc_example_1.py"
CHROMIUM = "/usr/bin/chromium"
CHROMEDRIVER = "/usr/bin/chromedriver"


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


def _tree_cpu_s(root_pid: int) -> float:
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


class HeadlessBrowser:
    """One headless Chromium (Debian's, driven by selenium) kept open for the whole run; `open()` shows the viewer
    page, `close()` navigates to about:blank: the page's cost, without the browser's start-up in it."""

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
        return _tree_cpu_s(self.service.process.pid)

    def open(self) -> None:
        self.driver.get(self.url)

    def close(self) -> None:
        self.driver.get("about:blank")

    def quit(self) -> None:
        self.driver.quit()


def frame_cost(redis: RedisSettings, track: str, observations: int = 120, frames: int = 300, steps: int = 3000) -> dict:
    """What the frame tap costs a worker: per step while nobody watches, per published frame while watched
    (real camera images of the track, JPEG encode and SET on the run's Redis), timed in the worker's own process."""
    env = DeepRacerEnv(EnvConfig(track=track))
    try:
        env.reset(seed=0)
        rng = np.random.default_rng(0)
        recorded = []
        for _ in range(observations):
            observation, reward, terminated, truncated, info = env.step(int(rng.integers(env.action_space.n)))
            recorded.append((observation, float(reward), info))
            if terminated or truncated:
                env.reset()
    finally:
        env.close()
    channel = FrameChannel(RedisLink(redis), "bench-frame-cost")
    channel.clear_watching()
    idle = FrameTap(channel, worker_id=0, world="base")
    wall_s, cpu_s = time.perf_counter(), time.process_time()
    for index in range(steps):
        idle(*recorded[index % len(recorded)])
    idle_wall_s, idle_cpu_s = time.perf_counter() - wall_s, time.process_time() - cpu_s
    channel.mark_watching()
    busy = FrameTap(channel, worker_id=0, world="base", settings=FrameSettings(max_fps=1e9))
    wall_s, cpu_s = time.perf_counter(), time.process_time()
    for index in range(frames):
        busy(*recorded[index % len(recorded)])
    busy_wall_s, busy_cpu_s = time.perf_counter() - wall_s, time.process_time() - cpu_s
    channel.clear_watching()
    jpeg_bytes = len(channel.latest(0).jpeg)
    return {
        "tap_us_per_step_unwatched": round(1e6 * idle_wall_s / steps, 2),
        "tap_cpu_us_per_step_unwatched": round(1e6 * idle_cpu_s / steps, 2),
        "frame_ms_published": round(1e3 * busy_wall_s / busy.published, 3),
        "frame_cpu_ms_published": round(1e3 * busy_cpu_s / busy.published, 3),
        "jpeg_bytes": jpeg_bytes,
    }


def _write_custom_files(folder: Path, episodes_per_iteration: int) -> None:
    folder.mkdir(parents=True)
    (folder / "reward_function.py").write_bytes(CENTRE_LINE_REWARD.read_bytes())
    actions = [{"steering_angle": angle, "speed": 1.0, "index": i} for i, angle in enumerate([-30, -15, 0, 15, 30])]
    (folder / "model_metadata.json").write_text(
        json.dumps(
            {
                "action_space": actions,
                "action_space_type": "discrete",
                "sensor": ["FRONT_FACING_CAMERA"],
                "neural_network": "DEEP_CONVOLUTIONAL_NETWORK_SHALLOW",
                "training_algorithm": "clipped_ppo",
                "version": "5",
            }
        )
    )
    (folder / "hyperparameters.json").write_text(json.dumps({"num_episodes_between_training": episodes_per_iteration}))
    (folder / "workers.json").write_text(json.dumps({"MIN_EVAL_TRIALS": 1}))


def _paired_ratios(records: list[dict]) -> list[float]:
    """Each page-open iteration's rate over the mean of its page-closed neighbours."""
    ratios = []
    for index, record in enumerate(records):
        if not record["page_open"]:
            continue
        neighbours = [
            records[j]["experience_steps_per_s"]
            for j in (index - 1, index + 1)
            if 0 <= j < len(records) and not records[j]["page_open"]
        ]
        if neighbours:
            ratios.append(record["experience_steps_per_s"] / statistics.fmean(neighbours))
    return ratios


@click.command(name="viewer")
@click.option("--iterations", type=int, default=16, show_default=True, help="Measured iterations (half with the page).")
@click.option("--warmup-iterations", type=int, default=2, show_default=True)
@click.option("--workers", "num_workers", type=int, default=4, show_default=True)
@click.option("--episodes-per-iteration", type=int, default=8, show_default=True)
@click.option("--track", default="racer_oval", show_default=True)
def viewer_bench_command(iterations, warmup_iterations, num_workers, episodes_per_iteration, track) -> None:
    """Experience steps/s with one viewer page open vs none, in one training run."""
    from racer.local_run import LocalRun, LocalRunPlan

    if not (Path(CHROMIUM).is_file() and Path(CHROMEDRIVER).is_file()):
        raise click.ClickException(f"{CHROMIUM} and {CHROMEDRIVER} are needed (scripts/setup.sh installs them)")
    if not CENTRE_LINE_REWARD.is_file():
        raise click.ClickException(f"reward function not found: {CENTRE_LINE_REWARD}")
    workdir = Path(tempfile.mkdtemp(prefix="racer-bench-viewer-"))
    custom = workdir / "custom_files"
    _write_custom_files(custom, episodes_per_iteration)
    port = _free_port()
    plan = LocalRunPlan(
        model_prefix="bench-viewer",
        custom_files=custom,
        num_workers=num_workers,
        worlds=WORLDS,
        track=track,
        max_episodes=10**6,
        max_minutes=None,
        use_minio=False,
        log_dir=workdir / "logs",
        viewer_port=port,
    )
    run = LocalRun(plan, ServiceSettings(redis=RedisSettings(), store=LocalStoreSettings(root=workdir / "store")))
    url = f"http://127.0.0.1:{port}/"
    records: list[dict] = []
    browser: HeadlessBrowser | None = None
    page_open = False
    page_cpu_s = page_wall_s = 0.0
    viewer_cpu_open_s = viewer_cpu_at_open = browser_cpu_at_open = page_opened = 0.0
    tap_cost: dict = {}
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    try:
        settings = run.start_services()
        click.echo("timing the frame tap alone ...", err=True)
        tap_cost = frame_cost(settings.redis, track)
        click.echo(json.dumps(tap_cost), err=True)
        run.start_processes()
        browser = HeadlessBrowser(url)
        link = RedisLink(settings.redis)
        channel, frames = RunChannel(link, plan.model_prefix), FrameChannel(link, plan.model_prefix)
        viewer_pid = run.children["viewer"].pid
        last_id = "0"
        total = warmup_iterations + iterations
        while len(records) < total:
            if run.children["trainer"].poll() is not None:
                raise click.ClickException(f"the trainer stopped; see {plan.log_dir / 'trainer.log'}")
            for stream_id, record in channel.read_records("iterations", last_id, block_s=5.0):
                last_id = stream_id
                record["page_open"] = page_open
                records.append(record)
                if page_open:  # the iteration that just ended ran with the page: close it
                    page_cpu_s += browser.cpu_s() - browser_cpu_at_open
                    page_wall_s += time.monotonic() - page_opened
                    viewer_cpu_open_s += _tree_cpu_s(viewer_pid) - viewer_cpu_at_open
                    browser.close()
                    page_open = False
                    frames.clear_watching()  # as if its key had expired: the next iteration runs without frames
                elif len(records) >= warmup_iterations:
                    viewer_cpu_at_open, browser_cpu_at_open = _tree_cpu_s(viewer_pid), browser.cpu_s()
                    browser.open()
                    page_open = True
                    page_opened = time.monotonic()
                click.echo(
                    f"iteration {record['iteration']:>3}: {record['experience_steps_per_s']:6.1f} steps/s "
                    f"{'(page open)' if record['page_open'] else ''}",
                    err=True,
                )
    finally:
        if browser is not None:
            browser.quit()
        run.stop()
        signal.signal(signal.SIGINT, previous)
    measured = records[warmup_iterations:]
    ratios = _paired_ratios(measured)
    closed = [r["experience_steps_per_s"] for r in measured if not r["page_open"]]
    opened = [r["experience_steps_per_s"] for r in measured if r["page_open"]]
    slowdown = 1.0 - statistics.median(ratios) if ratios else None
    click.echo(
        json.dumps(
            {
                "workers": num_workers,
                "iterations_measured": len(measured),
                "steps_per_s_page_closed": round(statistics.fmean(closed), 1) if closed else None,
                "steps_per_s_page_open": round(statistics.fmean(opened), 1) if opened else None,
                "paired_ratios": [round(r, 3) for r in ratios],
                "slowdown_median": None if slowdown is None else round(slowdown, 4),
                "browser_cpu_share_of_machine": round(page_cpu_s / max(page_wall_s, 1e-9) / os.cpu_count(), 4),
                "viewer_server_cpu_share_of_machine": round(
                    viewer_cpu_open_s / max(page_wall_s, 1e-9) / os.cpu_count(), 4
                ),
                "cpus": os.cpu_count(),
                **tap_cost,
                # A worker playing at full speed loses at most max_fps frames' time per second to the tap while watched.
                "tap_share_of_a_worker_at_4_fps": round(4 * tap_cost["frame_ms_published"] / 1000, 4),
            }
        )
    )
