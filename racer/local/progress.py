"""What `racer train` prints while it runs: a line per iteration and per evaluation, and the workers' states.

Each iteration line ends with how far the run is (iteration, time used of `--max-minutes` or episodes of the episode
limit, an estimate of the time left): the trainer's figures from the iteration's summary (racer.shared.run_progress),
the same the viewer shows. The status line every 30 s counts them on to the moment it is printed.
"""

from __future__ import annotations

import time

import click

from racer.shared.run_progress import RunProgress
from racer.shared.transport.channels import RunChannel


class ProgressDisplay:
    """Prints one line per finished iteration and per evaluation, plus a status line while waiting."""

    def __init__(self, channel: RunChannel, num_workers: int, started: float, echo=click.echo):
        self.channel = channel
        self.num_workers = num_workers
        self.started = started
        self.echo = echo
        self.iteration_id = "0"
        self.evaluation_id = "0"
        self.last_status = 0.0
        self.seen_workers: set[int] = set()
        self.progress: RunProgress | None = None
        """The newest iteration's progress figures (None before the first iteration, or from an older trainer)."""

    def poll(self) -> list[dict]:
        """Print what is new; return the new evaluation records (benchmarks watch them)."""
        for stream_id, record in self.channel.read_records("iterations", self.iteration_id):
            self.iteration_id = stream_id
            self.progress = progress_of(record)
            worlds = "  ".join(
                f"{world}: R={stats['mean_reward']:.1f} P={stats['mean_progress']:.0f}%"
                for world, stats in sorted(record["worlds"].items())
            )
            self.echo(
                f"[{self._elapsed()}] iteration {record['iteration']:>3}  episodes {record['episodes']:>3}  "
                f"steps {record['env_steps_total']:>8}  reward {record['mean_reward']:7.2f}  "
                f"progress {record['mean_progress']:5.1f}%  complete {record['completion_rate']:4.0%}  "
                f"{record['experience_steps_per_s']:6.0f} steps/s  | {worlds}"
                + (f"  | {self.progress.describe()}" if self.progress is not None else "")
            )
        evaluations = []
        for stream_id, record in self.channel.read_records("evaluations", self.evaluation_id):
            self.evaluation_id = stream_id
            evaluations.append(record)
            self.echo(
                f"[{self._elapsed()}] evaluation of {record['checkpoint']}: {record['laps_completed']}/{record['trials']} laps, "
                f"mean progress {record['mean_progress']:.1f}%"
                + (f", best lap {record['best_lap_time_s']:.2f} s" if record.get("best_lap_time_s") else "")
            )
        if time.monotonic() - self.last_status > 30:
            self.last_status = time.monotonic()
            live = self.channel.live_workers()
            self.seen_workers.update(live)
            states = ", ".join(f"w{i}:{self._worker_state(i, live)}" for i in range(self.num_workers))
            now = "" if self.progress is None else f"  | {self.progress.at(time.time()).describe()}"
            self.echo(f"[{self._elapsed()}] workers {states}{now}", err=True)
        return evaluations

    def _worker_state(self, worker_id: int, live: dict[int, dict]) -> str:
        """Its heartbeat's state; "starting" until its first heartbeat (importing, building its envs)."""
        if worker_id in live:
            return live[worker_id].get("state", "?")
        return "DOWN" if worker_id in self.seen_workers else "starting"

    def _elapsed(self) -> str:
        seconds = int(time.monotonic() - self.started)
        return f"{seconds // 60:02d}:{seconds % 60:02d}"


def progress_of(record: dict) -> RunProgress | None:
    """The `progress` of an iteration summary; None when it has none (a trainer of an older racer)."""
    raw = record.get("progress")
    if not isinstance(raw, dict):
        return None
    try:
        return RunProgress.from_dict(raw)
    except (KeyError, TypeError, ValueError):
        return None
