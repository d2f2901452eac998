"""What the viewer reads from the store: the same files in a live run and in a finished one.

Curves come from `metrics/iterations.jsonl` (the trainer appends one summary per iteration), in-training
evaluations from worker 0's `metrics/TrainingMetrics.json` with `model/deepracer_checkpoints.json`, laps from the
simtraces (racer.analysis reads them), `racer evaluate` runs from `evaluation-<ts>/summary.json` and their videos.
Reading from the store rather than Redis means a restarted Redis loses nothing on the page and a finished run
needs no Redis at all.
"""

from __future__ import annotations

import json
import math
import re
import threading
import time
from dataclasses import dataclass
from pathlib import Path, PurePosixPath

from racer.analysis.run_line import LineBook
from racer.shared.config import settings_from_env, store_settings_at
from racer.shared.deepracer.episode_status import EpisodeStatus
from racer.shared.deepracer.metrics import MetricsError, read_training_metrics
from racer.shared.deepracer.training_params import TrainingParamsError, parse_training_params
from racer.shared.model_layout import (
    DEEPRACER_CHECKPOINTS,
    EVALUATION_PREFIX,
    FINISHED,
    ITERATIONS_LOG,
    TRAINING_PARAMS,
    checkpoint_name,
    training_metrics,
)
from racer.shared.sim.tracks.track import Track, TrackError
from racer.shared.store import LocalStore, ObjectNotFoundError, ObjectStore, join_key, open_store
from racer.viewer.lap_bound import best_lap_bound
from racer.viewer.laps import BestLapFinder

_TRAINING_PARAMS = re.compile(r"^training_params(?:_(\d+))?\.yaml$")
_EVALUATION_SUMMARY = re.compile(rf"^({EVALUATION_PREFIX}[^/]+)/summary\.json$")
_VIDEO = re.compile(rf"^({EVALUATION_PREFIX}[^/]+)/(camera-[a-z0-9]+)/\d+-video\.mp4$")


class RunNotFoundError(Exception):
    """`racer view` was given something that is not a run; the message says where it looked."""


@dataclass(frozen=True)
class RunLocation:
    store: ObjectStore
    prefix: str

    def describe(self) -> str:
        return f"{self.prefix} in {self.store.describe()}"


def resolve_run(target: str) -> RunLocation:
    """A model folder on disk (`racer-data/MODEL`), `s3://bucket/MODEL`, or a model prefix in RACER_STORE."""
    path = Path(target).expanduser()
    if path.is_dir() and ((path / "model").is_dir() or (path / "metrics").is_dir()):
        location = RunLocation(LocalStore(path.resolve().parent), path.resolve().name)
    elif target.startswith("s3://"):
        bucket, _, prefix = target.removeprefix("s3://").partition("/")
        location = RunLocation(open_store(store_settings_at(f"s3://{bucket}")), prefix.strip("/"))
    else:
        location = RunLocation(open_store(settings_from_env().store), target.strip("/"))
    if not location.prefix or not location.store.list_keys(location.prefix + "/"):
        raise RunNotFoundError(
            f"{target}: no model folder (no files under {location.describe()}); give a folder "
            "such as racer-data/MODEL, s3://bucket/MODEL or a model prefix in RACER_STORE"
        )
    return location


def checkpoint_label(number: int, env_steps: int | None) -> str:
    """DeepRacer's checkpoint name `<N>_Step-<M>.ckpt` (the files may be gone: only 4 + best are kept)."""
    return checkpoint_name(number, env_steps) if env_steps is not None else f"checkpoint {number}"


def _finite(value) -> float | None:
    return None if value is None or (isinstance(value, float) and not math.isfinite(value)) else value


def _iterations_from_training_metrics(data: bytes, name: str) -> list[dict]:
    """Curves of a run racer did not train (DeepRacer console, DeepRacer-for-Cloud): worker 0's training episodes
    per iteration, as the console's reward graph shows them; no steps/s or per-world split there."""
    metrics = read_training_metrics(data, source=name)
    by_iteration: dict[int, list] = {}
    iteration = -1
    for entry in metrics.entries:
        if entry.phase == "training":
            if entry.trial == 1 or iteration < 0:
                iteration += 1
            by_iteration.setdefault(iteration, []).append(entry)
    return [
        {
            "iteration": number,
            "episodes": len(entries),
            "mean_reward": sum(e.reward_score for e in entries) / len(entries),
            "mean_progress": sum(e.completion_percentage for e in entries) / len(entries),
            "completion_rate": sum(e.episode_status == EpisodeStatus.LAP_COMPLETE for e in entries) / len(entries),
            "experience_steps_per_s": None,
            "env_steps_total": None,
            "elapsed_s": None,
            "worlds": {},
        }
        for number, entries in sorted(by_iteration.items())
    ]


class RunReader:
    """Cached reads of one run's files; each is read again only when its size changed (thread-safe)."""

    def __init__(self, location: RunLocation, lines: LineBook | None = None):
        """`lines`: where the best lap's lap-time bound comes from (None: no bound)."""
        self.location = location
        self.store = location.store
        self.prefix = location.prefix
        self._lock = threading.Lock()
        self._cache: dict[tuple[str, str], tuple[int, object]] = {}
        self.laps = BestLapFinder(self.store, self.prefix)
        self._workers: tuple[float, list[dict]] | None = None
        self._lines = lines
        self._bounds: dict[tuple, dict] = {}
        self._bounding: threading.Thread | None = None

    def key(self, *parts: str) -> str:
        return join_key(self.prefix, *parts)

    def _read(self, relative: str, parse):
        """Parsed content of a file under the prefix, None when missing; re-parsed only after its size changes."""
        key = self.key(relative)
        slot = (key, parse.__qualname__)  # one file may be parsed in two ways (TrainingMetrics.json)
        try:
            size = self.store.size(key)
        except ObjectNotFoundError:
            return None
        with self._lock:
            cached = self._cache.get(slot)
            if cached is not None and cached[0] == size:
                return cached[1]
        try:
            value = parse(self.store.get_bytes(key), key)
        except ObjectNotFoundError:
            return None
        with self._lock:
            self._cache[slot] = (size, value)
        return value

    # ---- the run's set-up --------------------------------------------------------------------------
    def worker_params(self) -> dict[int, dict[str, str]]:
        """training_params of each worker that has its own file (worker 0's applies to all others too)."""
        found = {}
        for key in self.store.list_keys(self.key(TRAINING_PARAMS.removesuffix(".yaml"))):
            match = _TRAINING_PARAMS.match(PurePosixPath(key).name)
            if match is None:
                continue
            try:
                params = self._read(
                    key[len(self.prefix) + 1 :],
                    lambda data, name: parse_training_params(data.decode("utf-8-sig"), name),
                )
            except (TrainingParamsError, UnicodeDecodeError):
                continue
            if params is not None:
                found[int(match.group(1) or 0)] = {k: str(v) for k, v in params.values.items()}
        return found

    def workers(self) -> list[dict]:
        """[{id, world, track}] for NUM_WORKERS workers, from the params files (listed again at most every 15 s:
        the live page asks on every poll)."""
        now = time.monotonic()
        with self._lock:
            cached = self._workers
        if cached is not None and now - cached[0] < (15.0 if cached[1] else 2.0):
            return cached[1]
        found = self._read_workers()
        with self._lock:
            self._workers = (now, found)
        return found

    def _read_workers(self) -> list[dict]:
        params = self.worker_params()
        if not params:
            return []
        first = params[min(params)]
        count = max(int(first.get("NUM_WORKERS", "1") or 1), max(params) + 1)
        return [
            {
                "id": i,
                "world": params.get(i, first).get("RACER_WORLD", "base"),
                "track": params.get(i, first).get("WORLD_NAME", ""),
            }
            for i in range(count)
        ]

    def track(self) -> dict | None:
        """Borders and centre line of worker 0's track (for the map), None when the route cannot be found."""
        workers = self.workers()
        name = workers[0]["track"] if workers else ""
        if not name:
            return None
        try:
            track = Track.load(name)
        except (TrackError, OSError):
            return {"name": name, "error": f"route {name!r} is not in the tracks folder: no map"}

        def points(array) -> list[list[float]]:
            return [[round(float(x), 4), round(float(y), 4)] for x, y in array]

        return {
            "name": name,
            "length_m": round(track.length_m, 3),
            "center": points(track.center_line),
            "inner": points(track.inner_border),
            "outer": points(track.outer_border),
        }

    # ---- progress ----------------------------------------------------------------------------------
    def iterations(self) -> list[dict]:
        def parse(data: bytes, name: str) -> list[dict]:
            records = []
            for line in data.decode().splitlines():
                if line.strip():
                    try:
                        records.append(json.loads(line))
                    except json.JSONDecodeError:
                        break  # a line being appended to (S3 replaces the whole object, a local file too)
            return records

        records = self._read(ITERATIONS_LOG, parse)
        if records is not None:
            return records
        return self._read(training_metrics(0), _iterations_from_training_metrics) or []

    def evaluations(self) -> list[dict]:
        """Worker 0's greedy evaluation of each checkpoint: trials, laps, mean progress, best lap, best flag."""
        metrics = self._read(training_metrics(0), lambda data, name: read_training_metrics(data, source=name))
        if metrics is None:
            return []
        steps_after = {
            int(r["iteration"]): r["env_steps_total"] for r in self.iterations() if r.get("env_steps_total") is not None
        }
        best_and_last = self._read(DEEPRACER_CHECKPOINTS, lambda data, name: json.loads(data)) or {}
        best = (best_and_last.get("best_checkpoint") or {}).get("name")
        by_checkpoint: dict[int, list] = {}
        iteration = -1
        for entry in metrics.entries:
            if entry.phase == "training" and (entry.trial == 1 or iteration < 0):
                iteration += 1
            elif entry.phase == "evaluation":
                by_checkpoint.setdefault(max(iteration, 0), []).append(entry)
        rows = []
        for number, entries in sorted(by_checkpoint.items()):
            laps = [e.elapsed_time_ms / 1000 for e in entries if e.episode_status == EpisodeStatus.LAP_COMPLETE]
            steps = steps_after.get(number - 1) if number else (0 if steps_after else None)
            name = checkpoint_label(number, steps)
            rows.append(
                {
                    "checkpoint_number": number,
                    "checkpoint": name,
                    "trials": len(entries),
                    "laps_completed": len(laps),
                    "mean_progress": round(sum(e.completion_percentage for e in entries) / len(entries), 2),
                    "best_lap_time_s": min(laps) if laps else None,
                    "is_best": name == best,
                }
            )
        return rows

    def evaluation_runs(self) -> list[dict]:
        """`racer evaluate` runs: their summary (laps) and the URLs of their videos."""
        runs: dict[str, dict] = {}
        for key in self.store.list_keys(self.key(EVALUATION_PREFIX)):
            relative = key[len(self.prefix) + 1 :]
            summary = _EVALUATION_SUMMARY.match(relative)
            video = _VIDEO.match(relative)
            if summary:
                runs.setdefault(summary.group(1), {"name": summary.group(1), "videos": []})["summary"] = relative
            elif video:
                runs.setdefault(video.group(1), {"name": video.group(1), "videos": []})["videos"].append(
                    {"view": video.group(2).removeprefix("camera-"), "url": "/files/" + relative}
                )
        result = []
        for name in sorted(runs, reverse=True):
            run = runs[name]
            summary = self._read(run["summary"], lambda data, key: json.loads(data)) if "summary" in run else None
            laps = [
                {k: lap.get(k) for k in ("lap", "label", "lap_time_s", "elapsed_s", "progress_pct", "put_backs")}
                for lap in (summary or {}).get("laps", [])
            ]
            result.append(
                {
                    "name": name,
                    "mode": (summary or {}).get("mode"),
                    "checkpoint": (summary or {}).get("checkpoint"),
                    "laps_completed": (summary or {}).get("laps_completed"),
                    "best_lap_time_s": _finite((summary or {}).get("best_lap_time_s")),
                    "laps": laps,
                    "videos": sorted(run["videos"], key=lambda v: v["view"]),
                }
            )
        return result

    def best_lap_bound(self, best: dict | None) -> dict | None:
        """The best lap's ratio to its car's lap-time bound (racer.viewer.lap_bound), None while its line is being
        computed: in a thread of its own, since a line takes tens of seconds and a poll must not wait."""
        if self._lines is None or not best or not best.get("complete"):
            return None
        lines = self._lines
        key = (best["run"], best["worker"], best["iteration"], best["episode"], best["lap_time_s"])
        with self._lock:
            if key in self._bounds:
                return self._bounds[key]
            if self._bounding is not None and self._bounding.is_alive():
                return None

            def compute() -> None:
                found = best_lap_bound(self, best, lines)
                with self._lock:
                    self._bounds[key] = found

            self._bounding = threading.Thread(target=compute, name="viewer-lap-bound", daemon=True)
            self._bounding.start()
        return None

    def finished(self) -> bool:
        return self.store.exists(self.key(FINISHED))

    def progress(self) -> dict:
        try:
            evaluations = self.evaluations()
        except MetricsError as error:
            evaluations, note = [], str(error)
        else:
            note = None
        best = self.laps.best()
        return {
            "iterations": self.iterations(),
            "evaluations": evaluations,
            "best_lap": best,
            "best_lap_bound": self.best_lap_bound(best),
            "evaluation_runs": self.evaluation_runs(),
            "finished": self.finished(),
            "note": note,
        }
