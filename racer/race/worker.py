"""One entrant's race, in its own process: import it if need be, then evaluate it as `racer evaluate` would.

    python -m racer.race.worker TASK.json     # writes the result JSON named in the task; exit 0 even when the
                                              # entrant failed (the result says why); a crash leaves no result

Whatever goes wrong becomes the result's `code` (the console's import error code, racer.model_io.codes) and
`reason`, so one broken entrant never stops the race.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import traceback
from pathlib import Path
from typing import Any

from racer.model_io.codes import ProblemCode
from racer.race.guard import PolicyGuard, PolicyReturnedNaN, RaceTimeLimit
from racer.race.lap_trace import best_lap_trace
from racer.race.race_file import parse_race
from racer.race.rules import evaluation_config
from racer.shared.store import LocalStore, ObjectNotFoundError, ObjectStore

IMPORT_TIMEOUT_S = 1800


class EntrantFailure(Exception):
    def __init__(self, reason: str, code: str | None = None) -> None:
        super().__init__(reason)
        self.reason = reason
        self.code = code


def _console_code(output: str) -> str | None:
    codes = {code.value for code in ProblemCode}
    for line in output.splitlines():
        first = line.split(" ", 1)[0].strip()
        if first in codes:
            return first
    return None


def import_entrant(task: dict[str, Any], store: ObjectStore, log) -> list[str]:
    """`racer model import` into a scratch store, then copy to races/<race>/<entrant>; returns its notes."""
    scratch = Path(task["work_dir"]) / "import-store"
    shutil.rmtree(scratch, ignore_errors=True)
    command = [sys.executable, "-m", "racer.cli", "model", "import", task["source"], task["name"]]
    command += ["--store", str(scratch), "--overwrite"]
    log(f"importing {task['source']}: {' '.join(command[3:])}")
    try:
        done = subprocess.run(command, capture_output=True, text=True, timeout=IMPORT_TIMEOUT_S, check=False)
    except subprocess.TimeoutExpired:
        raise EntrantFailure(f"racer model import took more than {IMPORT_TIMEOUT_S} s", "SERVICE_ERROR") from None
    output = done.stdout + done.stderr
    log(output)
    if done.returncode != 0:
        code = _console_code(output)
        lines = [line.strip() for line in output.splitlines() if line.strip() and not line.startswith("    fix:")]
        if code is not None:
            lines = [line.removeprefix(code).strip() for line in lines if line.startswith(code)][:1] + lines[-1:]
        summary = "; ".join(lines[-2:]) if lines else f"exit status {done.returncode}"
        raise EntrantFailure(f"racer model import failed: {summary}", code or "SERVICE_ERROR")
    source = LocalStore(scratch)
    prefix = task["model_prefix"]
    for key in store.list_keys(prefix + "/"):
        store.delete(key)
    for key in source.list_keys(task["name"] + "/"):
        store.put_bytes(prefix + "/" + key.removeprefix(task["name"] + "/"), source.get_bytes(key))
    shutil.rmtree(scratch, ignore_errors=True)
    return [line for line in output.splitlines() if line.startswith(("warning:", "note:"))]


def _load(store: ObjectStore, prefix: str):
    from racer.evaluation_worker.runner import read_model_metadata
    from racer.shared.deepracer.model_metadata import ModelMetadataError
    from racer.shared.policy.checkpoints import CheckpointStore
    from racer.shared.policy.manifest import CheckpointError

    checkpoints = CheckpointStore(store, prefix)
    try:
        checkpoint = checkpoints.select("best")
        policy = checkpoints.load_inference_policy(checkpoint)
        metadata = read_model_metadata(store, checkpoints, prefix, checkpoint)
    except ObjectNotFoundError as error:
        raise EntrantFailure(f"{prefix}: a file is missing: {error}", "FILE_DOES_NOT_EXIST") from None
    except CheckpointError as error:
        raise EntrantFailure(f"{prefix}: {error}", "CHECKPOINT_FILES_DOES_NOT_EXIST") from None
    except ModelMetadataError as error:
        raise EntrantFailure(f"{prefix}: {error}", "MODEL_VALIDATION_SERVICE_ERROR") from None
    return checkpoint, policy, metadata


def _metrics_so_far(store: ObjectStore, key: str) -> list[dict[str, Any]]:
    try:
        return list(json.loads(store.get_bytes(key))["metrics"])
    except ObjectNotFoundError:
        return []


def race_entrant(task: dict[str, Any], store: ObjectStore, log) -> dict[str, Any]:
    from racer.evaluation_worker.runner import EvaluationSession
    from racer.evaluation_worker.video import VIEWS

    definition = parse_race(task["race"], task["race_source"], task["race"]["name"])
    notes: list[str] = []
    if task["kind"] == "missing":
        raise EntrantFailure(
            f"{task['source']}: no model with that prefix in {store.describe()} and no such file or folder",
            "FILE_DOES_NOT_EXIST",
        )
    if task["kind"] == "import":
        notes = import_entrant(task, store, log)
    prefix = task["model_prefix"]
    try:
        checkpoint, policy, metadata = _load(store, prefix)
    except EntrantFailure as failure:
        if notes:
            failure.reason += " (" + " ".join(notes) + ")"
        raise
    config = evaluation_config(
        definition, route=task["route"], model_prefix=prefix, seed=task["seed"], video=task["video"]
    )
    guard = PolicyGuard(policy, time_limit_s=definition.max_time_minutes * 60.0)
    out_dir = Path(task["work_dir"]) / "evaluation"
    try:
        session = EvaluationSession(store, config, policy=guard, model_metadata=metadata, out_dir=out_dir)
    except ValueError as error:  # the model's sensors or action space do not fit this race / simulator
        raise EntrantFailure(f"the race cannot run this model: {error}") from None
    guard.attach(session.driver)
    metrics_key = session.layout.key(session.layout.relative("metrics"))
    result: dict[str, Any] = {"checkpoint": checkpoint, "evaluation": session.layout.key(session.layout.run_name)}
    try:
        report = session.run(log=log)
    except RaceTimeLimit as limit:
        result.update(metrics=_metrics_so_far(store, metrics_key), ended_by=str(limit))
        return result
    except PolicyReturnedNaN as error:
        raise EntrantFailure(str(error)) from None
    result["metrics"] = report.metrics.to_dict()["metrics"]
    result["ended_by"] = "maximumLaps" if len(report.laps) == definition.maximum_laps else "reset rule"
    local = report.local_dir or out_dir
    videos = {}
    if task["video"]:
        videos_dir = Path(task["videos_dir"])
        videos_dir.mkdir(parents=True, exist_ok=True)
        for view in VIEWS:
            path = local / session.layout.video(view)
            if path.is_file():
                target = videos_dir / f"{task['name']}-{view}.mp4"
                shutil.move(path, target)
                videos[view] = target.name
    result["videos"] = videos
    result["best_lap"] = best_lap_trace(local / session.layout.relative("simtrace"), report.laps)
    return result


def run_task(task_path: Path) -> None:
    task = json.loads(task_path.read_text())
    from racer.shared.config import settings_from_env
    from racer.shared.store import open_store

    log_path = Path(task["work_dir"]) / "race.log"
    log_path.parent.mkdir(parents=True, exist_ok=True)
    with log_path.open("a", encoding="utf-8") as log_file:

        def log(line: str) -> None:
            log_file.write(line.rstrip("\n") + "\n")
            log_file.flush()

        result: dict[str, Any] = {"entrant": task["name"]}
        try:
            store = open_store(settings_from_env().store)
            result.update(race_entrant(task, store, log))
        except EntrantFailure as failure:
            result.update(reason=failure.reason, code=failure.code)
        except Exception as error:  # noqa: BLE001 (any other failure is this entrant's, never the race's)
            log(traceback.format_exc())
            result.update(reason=f"the evaluation died: {type(error).__name__}: {error}", code=None)
    Path(task["result_path"]).write_text(json.dumps(result, indent=1) + "\n")


if __name__ == "__main__":
    run_task(Path(sys.argv[1]))
