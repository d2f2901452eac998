"""What `racer train` prints while it runs: a line per iteration and per evaluation, and the workers' states."""

from __future__ import annotations

import time

import click

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

    def poll(self) -> list[dict]:
        """Print what is new; return the new evaluation records (benchmarks watch them)."""
        for stream_id, record in self.channel.read_records("iterations", self.iteration_id):
            self.iteration_id = stream_id
            worlds = "  ".join(
                f"{world}: R={stats['mean_reward']:.1f} P={stats['mean_progress']:.0f}%"
                for world, stats in sorted(record["worlds"].items())
            )
            self.echo(
                f"[{self._elapsed()}] iteration {record['iteration']:>3}  episodes {record['episodes']:>3}  "
                f"steps {record['env_steps_total']:>8}  reward {record['mean_reward']:7.2f}  "
                f"progress {record['mean_progress']:5.1f}%  complete {record['completion_rate']:4.0%}  "
                f"{record['experience_steps_per_s']:6.0f} steps/s  | {worlds}"
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
            self.echo(f"[{self._elapsed()}] workers {states}", err=True)
        return evaluations

    def _worker_state(self, worker_id: int, live: dict[int, dict]) -> str:
        """Its heartbeat's state; "starting" until its first heartbeat (importing, building its envs)."""
        if worker_id in live:
            return live[worker_id].get("state", "?")
        return "DOWN" if worker_id in self.seen_workers else "starting"

    def _elapsed(self) -> str:
        seconds = int(time.monotonic() - self.started)
        return f"{seconds // 60:02d}:{seconds % 60:02d}"
