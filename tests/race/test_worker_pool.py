"""The race's long-lived workers: tasks run one after another in one process, and a worker that dies takes only its
own entrant with it (the pool starts another worker for the rest).

The tasks name entrants that are not there, so each is a store look-up, not an evaluation; the dying task is a task
file that is not JSON, which kills the worker the way a native crash would, without writing a result.
"""

from __future__ import annotations

import json
import os

from racer.race.race_file import parse_race
from racer.race.worker_pool import WorkerPool

RACE = {
    "name": "pool-cup",
    "trackConfig": {"trackId": "racer_oval"},
    "raceType": "TIME_TRIAL",
    "timingMethod": "BEST_LAP_TIME",
    "submissionTerminationConditions": {"minimumLaps": 1, "maximumLaps": 1, "maxTimeInMinutes": 1},
}


def write_task(root, name: str, broken: bool = False):
    work = root / "entrants" / name
    work.mkdir(parents=True)
    task = {
        "name": name,
        "source": f"no-such-{name}",
        "kind": "missing",
        "model_prefix": f"races/pool-cup/{name}",
        "race": parse_race(RACE, "pool.yaml", "pool-cup").to_dict(),
        "race_source": "pool.yaml",
        "work_dir": str(work),
        "result_path": str(work / "result.json"),
    }
    path = work / "task.json"
    path.write_text("{ not json" if broken else json.dumps(task))
    return path


def run_all(pool: WorkerPool, tasks) -> dict:
    """One task at a time, each to the pool's one worker; the Finished of each, by label."""
    finished = []
    try:
        for index, task in enumerate(tasks):
            pool.submit(task.parent.name, task)
            assert not pool.has_room()
            while pool.busy():
                finished += pool.wait()
            assert len(finished) == index + 1
    finally:
        pool.close()
    return {done.label: done for done in finished}


def read_result(root, name: str) -> dict:
    return json.loads((root / "entrants" / name / "result.json").read_text())


def test_one_worker_runs_tasks_in_turn_and_retires_after_its_share(tmp_path):
    env = {**os.environ, "RACER_STORE": str(tmp_path / "store")}
    tasks = [write_task(tmp_path, name) for name in ("alpha", "beta", "gamma")]
    done = run_all(WorkerPool(1, env, tasks_per_worker=2), tasks)
    assert all(done[name].exit_status is None for name in ("alpha", "beta", "gamma"))
    for name in ("alpha", "beta", "gamma"):
        result = read_result(tmp_path, name)
        assert result["entrant"] == name and result["code"] == "FILE_DOES_NOT_EXIST", result
    assert done["alpha"].pid == done["beta"].pid  # one process, two entrants
    assert done["gamma"].pid != done["beta"].pid  # the first retired after its two


def test_a_dead_worker_loses_only_its_entrant(tmp_path):
    env = {**os.environ, "RACER_STORE": str(tmp_path / "store")}
    tasks = [write_task(tmp_path, "alpha"), write_task(tmp_path, "boom", broken=True), write_task(tmp_path, "gamma")]
    done = run_all(WorkerPool(1, env), tasks)
    assert done["alpha"].exit_status is None and done["gamma"].exit_status is None
    assert read_result(tmp_path, "gamma")["code"] == "FILE_DOES_NOT_EXIST"
    assert done["boom"].exit_status not in (None, 0)
    assert done["gamma"].pid != done["alpha"].pid  # a new worker took the rest
    assert not (tmp_path / "entrants" / "boom" / "result.json").exists()
    assert "JSONDecodeError" in (tmp_path / "entrants" / "boom" / "stderr.log").read_text()
