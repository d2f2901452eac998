"""The other runs in the viewer's store: the page lists them and can lay a finished run's curves over the shown one.

A run is a model prefix with one of the files a run leaves (racer's iterations log, DeepRacer's TrainingMetrics.json,
model_metadata.json: racer.shared.model_layout); folders whose name starts with a dot (`racer train`'s logs in
`.runs/`) are not runs. Each run is read with its own RunReader, so its curves are exactly what the viewer shows for
it, and files are read again only when they changed (a size check per run when the page asks, every 15 s). The
store is listed again at most every `LIST_EVERY_S`: a bucket of many runs is a long listing.
"""

from __future__ import annotations

import threading
import time

from racer.shared.deepracer.metrics import MetricsError
from racer.shared.model_layout import ITERATIONS_LOG, MODEL_METADATA, training_metrics
from racer.shared.store import ObjectStore
from racer.viewer.run_reader import RunLocation, RunReader

LIST_EVERY_S = 60.0
"""A new run shows within a minute; a listing of a bucket of many runs costs a request per 1000 keys."""
RUN_MARKERS = (ITERATIONS_LOG, training_metrics(0), MODEL_METADATA)
"""Files (relative to a model prefix) that make a prefix a run."""
CURVE_KEYS = ("iteration", "episodes", "mean_reward", "mean_progress", "completion_rate", "elapsed_s")
"""What an overlay draws of each iteration: the page's reward, progress and completion charts."""


def run_prefixes(keys: list[str]) -> list[str]:
    """The model prefixes among a store's keys, sorted; none inside a dot folder."""
    found = set()
    for key in keys:
        for marker in RUN_MARKERS:
            if key.endswith("/" + marker):
                prefix = key[: -len(marker) - 1]
                if prefix and not any(part.startswith(".") for part in prefix.split("/")):
                    found.add(prefix)
    return sorted(found)


class StoreRuns:
    """The runs of one store, for the page's run list and overlays (thread-safe: requests come in parallel)."""

    def __init__(self, store: ObjectStore, current: RunReader):
        self.store = store
        self.current = current
        self._lock = threading.Lock()
        self._listed: tuple[float, list[str]] | None = None
        self._readers: dict[str, RunReader] = {current.prefix: current}

    def prefixes(self) -> list[str]:
        now = time.monotonic()
        with self._lock:
            listed = self._listed
        if listed is not None and now - listed[0] < LIST_EVERY_S:
            return listed[1]
        prefixes = run_prefixes(self.store.list_keys(""))
        if self.current.prefix not in prefixes:
            prefixes = sorted([*prefixes, self.current.prefix])  # a live run before its first file
        with self._lock:
            self._listed = (now, prefixes)
        return prefixes

    def reader(self, prefix: str) -> RunReader | None:
        """The reader of a listed run; None for anything else (the page cannot name arbitrary keys)."""
        if prefix not in self.prefixes():
            return None
        with self._lock:
            if prefix not in self._readers:
                self._readers[prefix] = RunReader(RunLocation(self.store, prefix))
            return self._readers[prefix]

    def summaries(self) -> list[dict]:
        """Each run: name, this page's run or not, finished, iterations, the last iteration's scores and progress."""
        result = []
        for prefix in self.prefixes():
            reader = self.reader(prefix)
            try:
                iterations = reader.iterations()
                note = None
            except MetricsError as error:
                iterations, note = [], str(error)
            last = iterations[-1] if iterations else {}
            result.append(
                {
                    "name": prefix,
                    "current": prefix == self.current.prefix,
                    "finished": reader.finished(),
                    "iterations": len(iterations),
                    "mean_reward": last.get("mean_reward"),
                    "mean_progress": last.get("mean_progress"),
                    "progress": last.get("progress"),
                    "note": note,
                }
            )
        return result

    def curves(self, prefix: str) -> list[dict] | None:
        """The run's per-iteration curves (CURVE_KEYS); None when `prefix` is not a run of this store."""
        reader = self.reader(prefix)
        if reader is None:
            return None
        return [{key: record.get(key) for key in CURVE_KEYS} for record in reader.iterations()]
