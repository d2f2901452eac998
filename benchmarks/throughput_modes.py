"""The throughput bench's training runs: one `racer train` run per mode (strict, overlap) and worker count, and what
each one measured over its iterations after the first (the first includes building the envs).

cpu_busy is the race-pace time shares' measure (the run's processes' CPU seconds over cores × wall seconds) over that
window: a watcher thread notes, as each line of the run's iterations log appears, the time and the CPU seconds of
this process's descendants (live ones from /proc, reaped ones from RUSAGE_CHILDREN); the window runs from the first
line to the last.
"""

from __future__ import annotations

import contextlib
import os
import resource
import sys
import threading
import time
from dataclasses import dataclass, replace
from pathlib import Path

import click

from benchmarks.time_shares import time_shares
from benchmarks.workdir import read_iteration_records
from racer.local.run import LocalRunPlan, run_local_training
from racer.shared import model_layout
from racer.shared.config import LocalStoreSettings, RedisSettings, ServiceSettings

MODES = ("strict", "overlap")
WATCH_INTERVAL_S = 0.2
"""How often the watcher looks at the iterations log's size (a stat; /proc is read only when it grew)."""


def descendants_cpu_s() -> float:
    """CPU seconds of this process's children and their descendants: live ones (utime, stime and their own reaped
    children's) from /proc, reaped children from RUSAGE_CHILDREN."""
    parents: dict[int, int] = {}
    cpu_ticks: dict[int, int] = {}
    for entry in os.scandir("/proc"):
        if not entry.name.isdigit():
            continue
        try:
            with open(f"/proc/{entry.name}/stat", encoding="ascii") as stat:
                fields = stat.read().rsplit(")", 1)[1].split()
        except (OSError, IndexError):
            continue  # gone since the listing
        pid = int(entry.name)
        parents[pid] = int(fields[1])
        cpu_ticks[pid] = sum(int(value) for value in fields[11:15])  # utime stime cutime cstime
    own = os.getpid()
    live_ticks = sum(ticks for pid, ticks in cpu_ticks.items() if _descends_from(pid, own, parents))
    reaped = resource.getrusage(resource.RUSAGE_CHILDREN)
    return live_ticks / os.sysconf("SC_CLK_TCK") + reaped.ru_utime + reaped.ru_stime


def _descends_from(pid: int, ancestor: int, parents: dict[int, int]) -> bool:
    seen = 0
    while pid in parents and seen < 64:
        pid, seen = parents[pid], seen + 1
        if pid == ancestor:
            return True
    return False


@dataclass(frozen=True)
class CpuMark:
    lines: int
    """Lines of the iterations log when this mark was taken."""
    monotonic_s: float
    cpu_s: float


class LogWatcher(threading.Thread):
    """Takes a CpuMark each time the iterations log at `path` gains lines, until stopped."""

    def __init__(self, path: Path):
        super().__init__(daemon=True, name="throughput-log-watcher")
        self.path = path
        self.marks: list[CpuMark] = []
        self.stopping = threading.Event()

    def run(self) -> None:
        size = -1
        while not self.stopping.wait(WATCH_INTERVAL_S):
            size = self.look(size)

    def look(self, size_before: int) -> int:
        """A mark if the log grew by a line since it had `size_before` bytes; returns its size now (-1: none yet)."""
        try:
            size = self.path.stat().st_size
        except FileNotFoundError:
            return -1
        if size != size_before:
            lines = self.path.read_bytes().count(b"\n")
            if lines > (self.marks[-1].lines if self.marks else 0):
                self.marks.append(CpuMark(lines, time.monotonic(), descendants_cpu_s()))
        return size


@dataclass(frozen=True)
class ModeRun:
    records: list[dict]
    marks: list[CpuMark]


def train_one_mode(plan: LocalRunPlan, overlap: bool, workdir: Path) -> ModeRun:
    """One training run of `plan` in its own folder of `workdir` (store and logs), strict or overlapped."""
    folder = workdir / f"{plan.run.num_workers}-workers-{MODES[overlap]}"
    plan = replace(plan, run=replace(plan.run, overlap=overlap), log_dir=folder / "logs")
    base = ServiceSettings(redis=RedisSettings(), store=LocalStoreSettings(root=folder / "store"))
    watcher = LogWatcher(folder / "store" / plan.model_prefix / model_layout.ITERATIONS_LOG)
    watcher.start()
    try:
        with contextlib.redirect_stdout(sys.stderr):  # the run's progress lines: stdout is the bench's JSON line
            status = run_local_training(plan, base)
    finally:
        watcher.stopping.set()
        watcher.join()
    watcher.look(-1)  # the last line, written as the trainer finished
    if status != 0:
        raise click.ClickException(
            f"the {MODES[overlap]} training run failed (status {status}); logs in {plan.log_dir}"
        )
    return ModeRun(read_iteration_records(folder / "store", plan), watcher.marks)


def system_rates(records: list[dict]) -> dict:
    """Experience and end-to-end rates of the iterations after the first."""
    later = records[1:]
    if not later:
        raise click.ClickException("the run finished fewer than 2 iterations; nothing to measure after the warm-up")
    steps = [r["env_steps_total"] - previous["env_steps_total"] for previous, r in zip(records, later, strict=False)]
    rollout_s = [step / max(r["experience_steps_per_s"], 1e-9) for step, r in zip(steps, later, strict=True)]
    wall_s = later[-1]["elapsed_s"] - records[0]["elapsed_s"]
    update_s = sum(r.get("update_s", 0.0) for r in later)
    return {
        "update_share_of_wall": update_s / wall_s,
        "experience_steps_per_s": sum(steps) / sum(rollout_s),
        "end_to_end_steps_per_s": sum(steps) / wall_s,
        "rollout_share_of_wall": sum(rollout_s) / wall_s,
        "steps_measured": sum(steps),
    }


def cpu_window(marks: list[CpuMark], records: int) -> tuple[float, float]:
    """CPU and wall seconds from the first iteration's line to the last one's."""
    first = next((mark for mark in marks if mark.lines >= 1), None)
    last = next((mark for mark in marks if mark.lines >= records), None)
    if first is None or last is None or last.monotonic_s <= first.monotonic_s:
        raise click.ClickException(f"the iterations log's lines were not seen arriving ({len(marks)} marks)")
    return last.cpu_s - first.cpu_s, last.monotonic_s - first.monotonic_s


def mode_figures(run: ModeRun, cores: int) -> dict:
    """One mode's figures over the iterations after the first."""
    rates = system_rates(run.records)
    cpu_s, wall_s = cpu_window(run.marks, len(run.records))
    shares = time_shares(run.records, cpu_s, wall_s, cores, after_first=True)
    behind = [r["episodes_one_behind_share"] for r in run.records if "episodes_one_behind_share" in r]
    return {
        "end_to_end_env_steps_per_s": round(rates["end_to_end_steps_per_s"], 1),
        "cpu_busy": shares["cpu_busy"],
        "experience_steps_per_s": round(rates["experience_steps_per_s"], 1),
        "rollout_share_of_wall": round(rates["rollout_share_of_wall"], 3),
        "update_share_of_wall": round(rates["update_share_of_wall"], 3),
        "iterations": len(run.records),
        "steps_measured": rates["steps_measured"],
        "window_s": round(wall_s, 1),
        "system_cpu_ms_per_step": round(1e3 * cpu_s / max(1, rates["steps_measured"]), 3),
        "episodes_one_behind_share": behind,
        "time_shares": shares,
    }
