"""`python -m benchmarks viewer`: how much one open viewer page slows the experience rate of a training.

A real `racer train` run (4 workers by default, the live page on a loopback port) alternates iteration by
iteration between no page and one page open in a headless Chromium (Debian's `chromium`, driven by selenium and
kept running for the whole run). The page is loaded once, before the measured iterations (its load is timed
apart: a one-off, not what an open page costs); between its open iterations it is frozen through the DevTools
protocol (no timer, no poll, no drawing: as good as closed, which the browser's CPU while frozen shows) and the
`watching` key is deleted, so the workers publish no frames then. Each iteration's experience rate (steps played /
rollout wall time, from the trainer's iteration records) is compared with the mean of its neighbours under the
other condition, so slow drifts and the load of other processes cancel out as far as they can; by default the
policy does not learn (`--learning-rate`), so every iteration plays the same distribution of episodes. `--load` switches something else on instead of the page, to find where a slow-down comes
from: `frames` (only the `watching` key: the workers' frame tap, nothing polls), `polls` (the page's HTTP requests
made by a Python thread: tap + viewer server + Redis, no browser). The CPU seconds of the browser, the viewer
server, the workers and the whole machine are summed per condition. Before the training starts, the frame tap is
also timed alone in this process (per step unwatched, per published frame watched), which a busy machine disturbs
less. Prints one JSON line; progress on stderr.
"""

from __future__ import annotations

import json
import os
import signal
import socket
import statistics
import time
from pathlib import Path

import click
import numpy as np

from benchmarks.viewer_loads import (
    CHROMEDRIVER,
    CHROMIUM,
    HeadlessBrowser,
    PagePolls,
    WatchingOnly,
    machine_busy_s,
    tree_cpu_s,
)
from benchmarks.workdir import bench_workdir
from racer.defaults import DEFAULT_CUSTOM_FILES
from racer.options.track import track_option
from racer.options.training import workers_option
from racer.shared.config import LocalStoreSettings, RedisSettings, ServiceSettings
from racer.shared.deepracer.hyperparameters import HyperparametersError, parse_hyperparameters
from racer.shared.redis_connection import RedisLink
from racer.shared.run_settings import RunOptions
from racer.shared.sim.config import EnvConfig
from racer.shared.sim.env import DeepRacerEnv
from racer.shared.sim.scene.worlds import WORLD_NAMES as WORLDS
from racer.shared.transport.channels import RunChannel
from racer.shared.transport.frames import FrameChannel, FrameSettings, FrameTap

REWARD_FUNCTION = DEFAULT_CUSTOM_FILES / "reward_function.py"
"""racer's example reward: the bench's policy does not learn (lr 1e-8), so any reward serves."""


def _free_port() -> int:
    with socket.socket() as probe:
        probe.bind(("127.0.0.1", 0))
        return probe.getsockname()[1]


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


def _bench_hyperparameters(episodes_per_iteration: int, learning_rate: float) -> dict:
    """The bench model's hyperparameters.json, checked as the trainer checks it (a value DeepRacer refuses stops the
    bench before anything is made). The fewest epochs DeepRacer allows: the update is not what is measured, and a
    short one fits more pairs of rollouts into the run."""
    hyperparameters = {"num_episodes_between_training": episodes_per_iteration, "lr": learning_rate, "num_epochs": 3}
    try:
        parse_hyperparameters(hyperparameters, source="python -m benchmarks viewer options")
    except HyperparametersError as error:
        raise click.ClickException(str(error)) from error
    return hyperparameters


def _write_custom_files(folder: Path, hyperparameters: dict) -> None:
    folder.mkdir(parents=True)
    (folder / "reward_function.py").write_bytes(REWARD_FUNCTION.read_bytes())
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
    (folder / "hyperparameters.json").write_text(json.dumps(hyperparameters))
    (folder / "workers.json").write_text(json.dumps({"MIN_EVAL_TRIALS": 1}))


def _paired_ratios(records: list[dict]) -> list[float]:
    """Each load-on iteration's rate over the mean of its load-off neighbours."""
    ratios = []
    for index, record in enumerate(records):
        if not record["load_on"]:
            continue
        neighbours = [
            records[j]["experience_steps_per_s"]
            for j in (index - 1, index + 1)
            if 0 <= j < len(records) and not records[j]["load_on"]
        ]
        if neighbours:
            ratios.append(record["experience_steps_per_s"] / statistics.fmean(neighbours))
    return ratios


class PhaseCosts:
    """CPU seconds of the load (browser or poller), the viewer server, the workers and the whole machine, and
    wall seconds, summed separately over the load-on and the load-off phases."""

    NAMES = ("wall_s", "load_cpu_s", "viewer_cpu_s", "workers_cpu_s", "machine_busy_s")

    def __init__(self, load, viewer_pid: int, worker_pids: list[int]):
        self.load, self.viewer_pid, self.worker_pids = load, viewer_pid, worker_pids
        self.totals = {on: dict.fromkeys(self.NAMES, 0.0) for on in (True, False)}
        self._last: tuple[float, ...] | None = None

    def _now(self) -> tuple[float, ...]:
        return (
            time.monotonic(),
            self.load.cpu_s(),
            tree_cpu_s(self.viewer_pid),
            sum(tree_cpu_s(pid) for pid in self.worker_pids),
            machine_busy_s(),
        )

    def mark(self, phase_was_on: bool | None) -> None:
        """Closes the phase that ran since the last mark (None: not measured) and starts the next one."""
        now = self._now()
        if self._last is not None and phase_was_on is not None:
            for name, value, before in zip(self.NAMES, now, self._last, strict=True):
                self.totals[phase_was_on][name] += value - before
        self._last = now

    def shares(self, on: bool) -> dict:
        """Each CPU figure as a share of the machine (all cores) over that phase's wall time."""
        totals = self.totals[on]
        capacity_s = max(totals["wall_s"], 1e-9) * os.cpu_count()
        return {name.removesuffix("_s"): round(totals[name] / capacity_s, 4) for name in self.NAMES[1:]}


@click.command(name="viewer")
@click.option("--iterations", type=int, default=12, show_default=True, help="Measured iterations (half with the load).")
@click.option(
    "--warmup-iterations",
    type=click.IntRange(min=2),
    default=2,
    show_default=True,
    help="Not measured; the page is loaded at the end of the first.",
)
@workers_option
@click.option(
    "--episodes-per-iteration",
    type=int,
    default=100,
    show_default=True,
    help="The frozen random policy's episodes last about 35 steps, so 100 (DeepRacer's most) make a rollout of about "
    "3,500 steps (8 s on 2 cores), about an iteration of a learning run whose car drives half a lap or more (20 "
    "episodes of 150-250 steps). With 32 (2-3 s of rollout) an iteration's rate is mostly its slowest episode's, the "
    "per-iteration start-up's and the page's once-per-iteration refresh.",
)
@track_option()
@click.option(
    "--learning-rate",
    type=float,
    default=1e-8,
    show_default=True,
    help="The trainer's lr. The default, the smallest DeepRacer accepts, leaves the policy as it starts, so every "
    "iteration plays the same distribution of episodes and a pair of iterations differs by the load alone; a learning "
    "policy moves the rate by ±20 % from one iteration to the next.",
)
@click.option(
    "--load",
    "load_kind",
    type=click.Choice(["page", "frames", "polls"]),
    default="page",
    show_default=True,
    help="What is on every other iteration: the page in Chromium, only the workers' frames, or the page's requests.",
)
@click.option(
    "--swap-phase",
    is_flag=True,
    help="The load on in the other half of the iterations (the training is deterministic: a second run with this "
    "flag puts the load on the iterations the first left without, so their lengths balance out).",
)
def viewer_bench_command(
    iterations, warmup_iterations, num_workers, episodes_per_iteration, track, learning_rate, load_kind, swap_phase
) -> None:
    """Experience steps/s with one viewer page open vs none, in one training run."""
    from racer.local.run import LocalRun, LocalRunPlan

    if load_kind == "page" and not (Path(CHROMIUM).is_file() and Path(CHROMEDRIVER).is_file()):
        raise click.ClickException(f"{CHROMIUM} and {CHROMEDRIVER} are needed (scripts/setup.sh installs them)")
    hyperparameters = _bench_hyperparameters(episodes_per_iteration, learning_rate)  # before the folder is made
    with bench_workdir("racer-bench-viewer-") as workdir:
        custom = workdir / "custom_files"
        _write_custom_files(custom, hyperparameters)
        port = _free_port()
        plan = LocalRunPlan(
            model_prefix="bench-viewer",
            custom_files=custom,
            run=RunOptions(num_workers=num_workers, track=track, worlds=WORLDS),
            max_episodes=10**6,
            max_minutes=None,
            use_minio=False,
            log_dir=workdir / "logs",
            viewer_port=port,
        )
        run = LocalRun(plan, ServiceSettings(redis=RedisSettings(), store=LocalStoreSettings(root=workdir / "store")))
        url = f"http://127.0.0.1:{port}/"
        records: list[dict] = []
        load = None
        load_on = False
        page_load: dict = {}
        tap_cost: dict = {}
        costs: PhaseCosts | None = None
        interrupted = False
        previous = signal.signal(signal.SIGINT, signal.default_int_handler)
        try:
            settings = run.start_services()
            click.echo("timing the frame tap alone ...", err=True)
            tap_cost = frame_cost(settings.redis, track)
            click.echo(json.dumps(tap_cost), err=True)
            run.start_processes()
            link = RedisLink(settings.redis)
            channel, frames = RunChannel(link, plan.model_prefix), FrameChannel(link, plan.model_prefix)
            load = {
                "page": lambda: HeadlessBrowser(url),
                "frames": lambda: WatchingOnly(frames),
                "polls": lambda: PagePolls(url),
            }[load_kind]()
            costs = PhaseCosts(
                load, run.children["viewer"].pid, [run.children[f"worker-{i}"].pid for i in range(num_workers)]
            )
            last_id = "0"
            total = warmup_iterations + iterations
            while len(records) < total:
                if run.children["trainer"].poll() is not None:
                    raise click.ClickException(f"the trainer stopped; see {plan.log_dir / 'trainer.log'}")
                for stream_id, record in channel.read_records("iterations", last_id, block_s=5.0):
                    last_id = stream_id
                    record["load_on"] = load_on
                    records.append(record)
                    measured = len(records) > warmup_iterations  # the iteration that just ended counts
                    costs.mark(load_on if measured else None)
                    if len(records) == 1:
                        cpu_before, wall_before = load.cpu_s(), time.monotonic()
                        load.load()
                        time.sleep(3.0)  # the page's first polls and charts
                        load.stop()
                        frames.clear_watching()
                        page_load = {
                            "load_cpu_s_first_3s": round(load.cpu_s() - cpu_before, 2),
                            "load_wall_s": round(time.monotonic() - wall_before, 2),
                        }
                        click.echo(json.dumps(page_load), err=True)
                        costs.mark(None)
                    elif load_on:  # the iteration that just ended ran with the load: switch it off
                        load.stop()
                        load_on = False
                        frames.clear_watching()  # as if its key had expired: the next iteration runs without frames
                    elif len(records) >= warmup_iterations + (1 if swap_phase else 0):
                        load.start()
                        load_on = True
                    click.echo(
                        f"iteration {record['iteration']:>3}: {record['experience_steps_per_s']:6.1f} steps/s, {record['episodes']} episodes "
                        f"{'(' + load_kind + ' on)' if record['load_on'] else ''}",
                        err=True,
                    )
        except KeyboardInterrupt:  # Ctrl-C: what was measured so far is still worth printing
            interrupted = True
            click.echo("interrupted: the summary covers the iterations measured so far", err=True)
        finally:
            if load is not None:
                load.quit()
            run.stop()
            signal.signal(signal.SIGINT, previous)
        if costs is None or len(records) <= warmup_iterations:
            raise click.ClickException("interrupted before any measured iteration")
        measured = records[warmup_iterations:]
        ratios = _paired_ratios(measured)
        closed = [r["experience_steps_per_s"] for r in measured if not r["load_on"]]
        opened = [r["experience_steps_per_s"] for r in measured if r["load_on"]]
        slowdown = 1.0 - statistics.median(ratios) if ratios else None
        steps_in = {on: _phase_steps(records, warmup_iterations, on) for on in (True, False)}
        click.echo(
            json.dumps(
                {
                    "load": load_kind,
                    "swap_phase": swap_phase,
                    "interrupted": interrupted,
                    "workers": num_workers,
                    "learning_rate": learning_rate,
                    "iterations_measured": len(measured),
                    "steps_per_s_load_off": round(statistics.fmean(closed), 1) if closed else None,
                    "steps_per_s_load_on": round(statistics.fmean(opened), 1) if opened else None,
                    "paired_ratios": [round(r, 3) for r in ratios],
                    "slowdown_median": None if slowdown is None else round(slowdown, 4),
                    "paired_ratio_quartiles": (
                        [round(q, 3) for q in statistics.quantiles(ratios, n=4)] if len(ratios) >= 2 else None
                    ),
                    "cpu_share_of_machine_load_on": costs.shares(True),
                    "cpu_share_of_machine_load_off": costs.shares(False),
                    "workers_cpu_ms_per_step": {
                        "on" if on else "off": round(1e3 * costs.totals[on]["workers_cpu_s"] / max(steps_in[on], 1), 3)
                        for on in (True, False)
                    },
                    "cpus": os.cpu_count(),
                    **page_load,
                    **tap_cost,
                    # A worker playing at full speed loses at most max_fps frames' time per second to the tap while watched.
                    "tap_share_of_a_worker_at_max_fps": round(
                        FrameSettings().max_fps * tap_cost["frame_ms_published"] / 1000, 4
                    ),
                }
            )
        )


def _phase_steps(records: list[dict], warmup_iterations: int, on: bool) -> int:
    """Env steps played in the measured iterations of one phase (from the trainer's running total)."""
    steps = 0
    for index in range(max(warmup_iterations, 1), len(records)):
        if records[index]["load_on"] == on:
            steps += records[index]["env_steps_total"] - records[index - 1]["env_steps_total"]
    return steps
