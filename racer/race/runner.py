"""Run every entrant, `workers` at a time, on long-lived race workers (racer.race.worker_pool).

A worker that dies without writing its result makes that entrant's row ("the evaluation died"), so the others
race on. Every entrant gets the race's seed, so the same file, entrants and seed give the same board.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from racer.race.entrants import Entrant
from racer.race.race_file import RaceDefinition
from racer.race.videos import ALL_CARS_TOP_VIEW
from racer.race.worker_pool import WorkerPool
from racer.shared.sim.generations.catalog import DEFAULT_GENERATION


@dataclass(frozen=True)
class RaceRun:
    results: tuple[dict[str, Any], ...]
    """One per entrant, in entrant order: the worker's result (metrics, videos, best lap) or its reason."""
    wall_s: float


def race_workers_for_the_cores() -> int:
    """Entrants racing at once when `racer race --workers` is not given: one per core, each in a process of its own
    (not rollout workers: racer.options.training.DEFAULT_WORKERS is those)."""
    return max(1, len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1)


def missing_result(entrant: Entrant) -> dict[str, Any]:
    return {
        "entrant": entrant.name,
        "reason": f"{entrant.source}: no model with that prefix in the store and no such file or folder",
        "code": "FILE_DOES_NOT_EXIST",
    }


def _task(
    entrant: Entrant, definition: RaceDefinition, route: str, seed: int, video: bool, out: Path, generation: str
) -> dict:
    work = out / "entrants" / entrant.name
    return {
        "name": entrant.name,
        "source": entrant.source,
        "kind": entrant.kind,
        "model_prefix": entrant.model_prefix,
        "race": definition.to_dict(),
        "race_source": definition.source,
        "route": route,
        "seed": seed,
        "generation": generation,
        "video": video,
        "work_dir": str(work),
        "videos_dir": str(out / "videos"),
        "result_path": str(work / "result.json"),
    }


def run_multi_car_race(
    definition: RaceDefinition,
    entrants: Sequence[Entrant],
    *,
    route: str,
    out_dir: Path,
    seed: int,
    video: bool,
    generation: str = DEFAULT_GENERATION,
    log: Callable[[str], None] = print,
) -> RaceRun:
    """HEAD_TO_MODEL / F1: every entrant in ONE multi-car evaluation, in one process (`racer.race.worker`); a
    process that dies leaves every entrant's row with the reason."""
    started = time.perf_counter()
    work = out_dir / "multi-car"
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    (out_dir / "videos" / ALL_CARS_TOP_VIEW).unlink(missing_ok=True)  # an earlier run's must not be linked
    task = {
        "multi_car": True,
        "entrants": [
            {"name": e.name, "source": e.source, "kind": e.kind, "model_prefix": e.model_prefix} for e in entrants
        ],
        "race": definition.to_dict(),
        "race_source": definition.source,
        "route": route,
        "seed": seed,
        "generation": generation,
        "video": video,
        "work_dir": str(work),
        "videos_dir": str(out_dir / "videos"),
        "result_path": str(work / "result.json"),
    }
    task_path = work / "task.json"
    task_path.write_text(json.dumps(task, indent=1) + "\n")
    env = {**os.environ, "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
    log(f"started {definition.race_type}: {', '.join(e.name for e in entrants)} on one track")
    with (work / "stderr.log").open("w") as stderr:
        done = subprocess.run(
            [sys.executable, "-m", "racer.race.worker", str(task_path)],
            stdout=stderr,
            stderr=subprocess.STDOUT,
            env=env,
        )
    result_path = Path(task["result_path"])
    if result_path.is_file():
        results = list(json.loads(result_path.read_text())["results"])
    else:
        reason = f"the evaluation died (exit status {done.returncode}; see {work / 'stderr.log'})"
        results = [{"entrant": e.name, "reason": reason, "code": None} for e in entrants]
    for result in results:
        outcome = result.get("reason") or f"{len(result.get('metrics', []))} laps"
        log(f"{result['entrant']}: {outcome}")
    return RaceRun(results=tuple(results), wall_s=time.perf_counter() - started)


def run_race(
    definition: RaceDefinition,
    entrants: Sequence[Entrant],
    *,
    route: str,
    out_dir: Path,
    seed: int,
    workers: int,
    video: bool,
    generation: str = DEFAULT_GENERATION,
    log: Callable[[str], None] = print,
) -> RaceRun:
    started = time.perf_counter()
    results: dict[str, dict[str, Any]] = {}
    tasks: list[tuple[Entrant, Path]] = []
    for entrant in entrants:
        if entrant.kind == "missing":  # nothing to start a worker for
            results[entrant.name] = missing_result(entrant)
            log(f"skipped {entrant.name}: {results[entrant.name]['reason']}")
            continue
        task = _task(entrant, definition, route, seed, video, out_dir, generation)
        work = Path(task["work_dir"])
        shutil.rmtree(work, ignore_errors=True)
        work.mkdir(parents=True)
        (work / "task.json").write_text(json.dumps(task, indent=1) + "\n")
        tasks.append((entrant, work / "task.json"))
    began: dict[str, float] = {}
    # One thread each for torch and llvmpipe's renderer: the workers already fill the cores.
    env = {"LP_NUM_THREADS": "1", **os.environ, "OMP_NUM_THREADS": "1", "MKL_NUM_THREADS": "1"}
    pool = WorkerPool(min(workers, max(1, len(tasks))), env)
    try:
        while tasks or pool.busy():
            while tasks and pool.has_room():
                entrant, task_path = tasks.pop(0)
                pool.submit(entrant.name, task_path)
                began[entrant.name] = time.perf_counter()
                log(f"started {entrant.name} ({entrant.kind}: {entrant.source})")
            for done in pool.wait():
                result_path = done.task_path.parent / "result.json"
                if done.exit_status is None and result_path.is_file():
                    result = json.loads(result_path.read_text())
                else:
                    result = {
                        "entrant": done.label,
                        "reason": f"the evaluation died (exit status {done.exit_status}; see "
                        f"{done.task_path.parent / 'stderr.log'})",
                        "code": None,
                    }
                results[done.label] = result
                outcome = result.get("reason") or f"{len(result.get('metrics', []))} laps"
                took_s = time.perf_counter() - began[done.label]
                log(f"finished {done.label} in {took_s:.1f} s (worker {done.pid}): {outcome}")
    finally:
        pool.close()
    return RaceRun(results=tuple(results[entrant.name] for entrant in entrants), wall_s=time.perf_counter() - started)
