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


def test_one_worker_runs_tasks_in_turn_and_a_dead_worker_loses_only_its_entrant(tmp_path):
    env = {**os.environ, "RACER_STORE": str(tmp_path / "store")}
    tasks = [write_task(tmp_path, "alpha"), write_task(tmp_path, "boom", broken=True), write_task(tmp_path, "gamma")]
    pool = WorkerPool(1, env)
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
    by_label = {done.label: done for done in finished}
    assert by_label["alpha"].exit_status is None and by_label["gamma"].exit_status is None
    for name in ("alpha", "gamma"):
        result = json.loads((tmp_path / "entrants" / name / "result.json").read_text())
        assert result["entrant"] == name and result["code"] == "FILE_DOES_NOT_EXIST", result
    assert by_label["boom"].exit_status not in (None, 0)
    assert not (tmp_path / "entrants" / "boom" / "result.json").exists()
    assert "JSONDecodeError" in (tmp_path / "entrants" / "boom" / "stderr.log").read_text()
