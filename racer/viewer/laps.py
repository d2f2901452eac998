"""The best lap so far and its path, from the run's simtraces, read incrementally.

Each simtrace CSV (one per worker and iteration, written whole once; one per `racer evaluate` run) is read once
with racer.analysis (the same lap times as `racer analyze`: an evaluation's from its EvaluationMetrics file when it has
one); only the best episode's path is kept. Without a
finished lap the episode that got furthest stands in, marked `complete: false`.
"""

from __future__ import annotations

import logging
import threading

from racer.analysis.aggregate import episodes, evaluation_laps
from racer.analysis.evaluation_times import timed_laps
from racer.analysis.loading import EPISODE_KEY, add_step_deltas, read_one
from racer.analysis.sources import EVALUATION, SimtraceFile, SimtraceFiles, classify
from racer.shared.deepracer.simtrace import SimtraceError
from racer.shared.model_layout import EVALUATION_PREFIX, evaluation_metrics
from racer.shared.store import ObjectNotFoundError, ObjectStore

log = logging.getLogger(__name__)

PATH_POINTS = 600


def _rank(candidate: dict) -> tuple:
    """Smaller is better: any finished lap beats any unfinished episode; then lap time, or progress."""
    if candidate["complete"]:
        return (0, candidate["lap_time_s"])
    return (1, -candidate["progress"], candidate["time_s"])


class BestLapFinder:
    def __init__(self, store: ObjectStore, prefix: str):
        self.store = store
        self.prefix = prefix
        self._seen: dict[str, int] = {}
        self._best: dict | None = None
        self._lock = threading.Lock()

    def _candidate(self, key: str) -> dict | None:
        relative = key[len(self.prefix) + 1 :]
        found = classify(relative)
        if found is None:
            return None
        phase, run, worker, iteration = found
        file = SimtraceFile(key, phase, run, worker, iteration, read_bytes=lambda: self.store.get_bytes(key))
        steps = add_step_deltas(read_one(file))
        table = episodes(steps)
        if table.empty:
            return None
        if phase == EVALUATION:
            table = self._metrics_times(run, table)
        complete = table[table["lap_complete"]]
        if len(complete):
            row = complete.sort_values("lap_time_s").iloc[0]
        else:
            row = table.sort_values(["progress_pct", "time_s"], ascending=[False, True]).iloc[0]
        mask = (steps[EPISODE_KEY] == row[EPISODE_KEY]).all(axis=1)
        path = steps.loc[mask & (steps["episode_status"] != "pause"), ["X", "Y"]].to_numpy()
        stride = max(1, -(-len(path) // PATH_POINTS))
        return {
            "complete": bool(row["lap_complete"]),
            "lap_time_s": round(float(row["lap_time_s"]), 3) if row["lap_complete"] else None,
            "progress": round(float(row["progress_pct"]), 2),
            "time_s": round(float(row["time_s"]), 3),
            "phase": phase,
            "run": run,
            "worker": int(worker),
            "iteration": int(iteration),
            "episode": int(row["episode"]),
            "steps": int(row["steps"]),
            "path": [[round(float(x), 3), round(float(y), 3)] for x, y in path[::stride]],
        }

    def _metrics_times(self, run: str, table):
        """The evaluation's laps timed as its EvaluationMetrics time them (evaluation_times), when the file is there."""
        timestamp = run.rsplit("/", 1)[-1].removeprefix(EVALUATION_PREFIX)
        key = f"{self.prefix}/{evaluation_metrics(timestamp)}"
        try:
            files = SimtraceFiles("", [], {}, evaluation_metrics={key: self.store.get_bytes(key)})
        except ObjectNotFoundError:
            return table
        laps = timed_laps(files, evaluation_laps(table.assign(run=f"{self.prefix}/{run}")), notes=[])
        return table.assign(lap_time_s=laps["lap_time_s"].to_numpy(), time_s=laps["time_s"].to_numpy())

    def best(self) -> dict | None:
        """Reads the simtraces that are new (or changed size) since the last call."""
        with self._lock:
            for key in self.store.list_keys(self.prefix + "/"):
                if not key.endswith("-iteration.csv"):
                    continue
                try:
                    size = self.store.size(key)
                    if self._seen.get(key) == size:
                        continue
                    candidate = self._candidate(key)
                except (ObjectNotFoundError, SimtraceError) as error:
                    log.warning("viewer: skipping %s: %s", key, error)
                    continue
                self._seen[key] = size
                if candidate is not None and (self._best is None or _rank(candidate) < _rank(self._best)):
                    self._best = candidate
            return self._best
