"""One entrant's race: import it if need be, then evaluate it as `racer evaluate` would.

    python -m racer.race.worker TASK.json     # writes the result JSON named in the task; exit 0 even when the
                                              # entrant failed (the result says why); a crash leaves no result
    python -m racer.race.worker --serve       # a long-lived worker (racer.race.runner): task paths on stdin, one
                                              # per line, "done PATH" on stdout after each

Whatever goes wrong becomes the result's `code` (the console's import error code, racer.model_io.codes) and
`reason`, so one broken entrant never stops the race.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import traceback
from pathlib import Path
from typing import Any

from racer.model_io.codes import ProblemCode
from racer.race.entrant_evaluation import evaluation_config
from racer.race.guard import PolicyGuard, PolicyReturnedNaN, RaceTimeLimit
from racer.race.lap_trace import best_lap_trace
from racer.race.race_file import parse_race
from racer.race.videos import ALL_CARS_TOP_VIEW, move_videos
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
        # stdin: a long-lived worker reads its task list there; the import must never take a line of it
        done = subprocess.run(
            command, stdin=subprocess.DEVNULL, capture_output=True, text=True, timeout=IMPORT_TIMEOUT_S, check=False
        )
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
        definition,
        route=task["route"],
        model_prefix=prefix,
        seed=task["seed"],
        video=task["video"],
        generation=task["generation"],
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
    result["videos"] = move_videos(local, session.layout, task, task["name"]) if task["video"] else {}
    result["best_lap"] = best_lap_trace(local / session.layout.relative("simtrace"), report.laps)
    return result


class _CarPolicyFailed(Exception):
    def __init__(self, index: int, reason: str) -> None:
        super().__init__(reason)
        self.index = index
        self.reason = reason


class _CarGuard:
    """A multi-car entrant's policy: NaN stops the race with the car's index, so it can run again without it."""

    def __init__(self, index: int, policy: Any) -> None:
        self.index = index
        self.guard = PolicyGuard(policy, time_limit_s=float("inf"))  # MultiCarRules.max_race_s stops the race

    def act(self, observation, greedy, generator=None, epsilon=0.0):
        try:
            return self.guard.act(observation, greedy, generator, epsilon)
        except PolicyReturnedNaN as error:
            raise _CarPolicyFailed(self.index, str(error)) from None


def _multi_car_row(report, car, result, rules, task: dict[str, Any], name: str) -> dict[str, Any]:
    place = result.finishing_order.index(car.index) + 1
    row: dict[str, Any] = {
        "metrics": report.metrics.to_dict()["metrics"],
        "ended_by": "finished" if car.finished else "did not finish",
        "multi_car": {
            "raceType": rules.race_type,
            "laps": rules.laps,
            "gridPlace": car.index + 1,
            "finishingPlace": place,
            "finished": car.finished,
            "parked": car.parked,
            "finishTimeMs": None if car.finish_time_s is None else int(round(car.finish_time_s * 1000.0)),
            "completedLaps": car.laps_completed,
            "racedPct": round(car.raced_pct, 3),
            "crashCount": car.crash_count,
        },
    }
    local = report.local_dir
    row["videos"] = move_videos(local, report.layout, task, name) if task["video"] and local is not None else {}
    if local is not None:
        row["best_lap"] = best_lap_trace(local / report.layout.relative("simtrace"), report.laps)
    return row


def race_multi_car(task: dict[str, Any], store: ObjectStore, log) -> list[dict[str, Any]]:
    """HEAD_TO_MODEL / F1: every entrant that loads races in ONE multi-car evaluation; the others get their rows.

    A car whose policy returns NaN, or whose model the simulator cannot run, is taken out and the race runs again
    without it (seeded, so the others' race is the one they would have had without it)."""
    import dataclasses

    from racer.evaluation_worker.multi_car_session import run_multi_car_evaluation
    from racer.shared.sim.objects.peer_cars import PeerCars

    definition = parse_race(task["race"], task["race_source"], task["race"]["name"])
    rules = definition.multi_car_rules()
    rows: dict[str, dict[str, Any]] = {}
    loaded: list[tuple[dict[str, Any], str, Any, Any]] = []
    for entrant in task["entrants"]:
        sub = {**task, **entrant, "work_dir": str(Path(task["work_dir"]) / entrant["name"])}
        try:
            if entrant["kind"] == "missing":
                raise EntrantFailure(
                    f"{entrant['source']}: no model with that prefix in {store.describe()} and no such file or folder",
                    "FILE_DOES_NOT_EXIST",
                )
            notes = import_entrant(sub, store, log) if entrant["kind"] == "import" else []
            try:
                checkpoint, policy, metadata = _load(store, entrant["model_prefix"])
            except EntrantFailure as failure:
                if notes:
                    failure.reason += " (" + " ".join(notes) + ")"
                raise
        except EntrantFailure as failure:
            rows[entrant["name"]] = {"reason": failure.reason, "code": failure.code}
            log(f"{entrant['name']}: {failure.reason}")
            continue
        loaded.append((entrant, checkpoint, policy, metadata))

    def config_of(entrant: dict[str, Any]):
        config = evaluation_config(
            definition,
            route=task["route"],
            model_prefix=entrant["model_prefix"],
            seed=task["seed"],
            video=task["video"],
            generation=task["generation"],
        )
        # racer's multi-car evaluation runs the laps continuously, one reset budget per car (multi_car.py)
        return dataclasses.replace(config, deepracer=dataclasses.replace(config.deepracer, is_continuous=True))

    out_dir = Path(task["work_dir"]) / "evaluation"
    while len(loaded) >= 2:
        configs = [config_of(entrant) for entrant, *_ in loaded]
        policies = [(_CarGuard(i, policy), metadata) for i, (_, _, policy, metadata) in enumerate(loaded)]
        try:
            reports, result = run_multi_car_evaluation(
                store,
                configs,
                rules,
                policies=policies,
                out_dir=out_dir,
                log=log,
                top_view=Path(task["videos_dir"]) / ALL_CARS_TOP_VIEW if task["video"] else None,
            )
        except _CarPolicyFailed as failure:
            entrant = loaded.pop(failure.index)[0]
            rows[entrant["name"]] = {"reason": failure.reason, "code": None}
            log(f"{entrant['name']}: {failure.reason}; the race runs again without it")
            shutil.rmtree(out_dir, ignore_errors=True)
            continue
        except ValueError as error:  # a model whose sensors or action space the simulator cannot run: find which
            unfit = []
            for i, (_, _, policy, metadata) in enumerate(loaded):
                try:
                    from racer.evaluation_worker.runner import EvaluationSession

                    probe = EvaluationSession(
                        store,
                        configs[i],
                        policy=policy,
                        model_metadata=metadata,
                        track_objects=PeerCars(i, len(loaded)),
                    )
                    probe.driver.close()
                    probe.env.close()
                except ValueError as reason:
                    unfit.append((i, str(reason)))
            if not unfit:
                raise
            for i, reason in reversed(unfit):
                entrant = loaded.pop(i)[0]
                rows[entrant["name"]] = {"reason": f"the race cannot run this model: {reason}", "code": None}
            log(f"{error}; the race runs again without {len(unfit)} car(s)")
            continue
        for (entrant, checkpoint, _, _), report, car in zip(loaded, reports, result.cars, strict=True):
            row = _multi_car_row(report, car, result, rules, task, entrant["name"])
            rows[entrant["name"]] = {
                "checkpoint": checkpoint,
                "evaluation": report.layout.key(report.layout.run_name),
                **row,
            }
        break
    for entrant, *_ in loaded:
        if entrant["name"] not in rows:
            rows[entrant["name"]] = {
                "reason": f"{definition.race_type} needs two or more cars; the other entrants could not race",
                "code": None,
            }
    return [{"entrant": entrant["name"], **rows[entrant["name"]]} for entrant in task["entrants"]]


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

        if task.get("multi_car"):
            _run_multi_car_task(task, log)
            return
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


def _run_multi_car_task(task: dict[str, Any], log) -> None:
    """The multi-car task's result file: {"results": [one row per entrant]}; a failure is every entrant's row."""
    from racer.shared.config import settings_from_env
    from racer.shared.store import open_store

    try:
        results = race_multi_car(task, open_store(settings_from_env().store), log)
    except Exception as error:  # noqa: BLE001 (the race's failure: every entrant's row says why)
        log(traceback.format_exc())
        reason = f"the multi-car evaluation died: {type(error).__name__}: {error}"
        results = [{"entrant": e["name"], "reason": reason, "code": None} for e in task["entrants"]]
    Path(task["result_path"]).write_text(json.dumps({"results": results}, indent=1) + "\n")


def serve() -> None:
    """Run the tasks named on stdin one after another in this process, so the imports (torch, MuJoCo, ONNX Runtime:
    seconds of CPU) are paid once per worker, not once per entrant. Each task's output, a native crash's last words
    included, goes to the stderr.log beside its task (fds 1 and 2 point there); the protocol has its own copy of fd 1.
    """
    protocol = os.fdopen(os.dup(1), "w", encoding="utf-8")
    for line in sys.stdin:
        task_path = Path(line.strip())
        sys.stdout.flush()
        sys.stderr.flush()
        with (task_path.parent / "stderr.log").open("w") as task_log:
            os.dup2(task_log.fileno(), 1)
            os.dup2(task_log.fileno(), 2)
            run_task(task_path)
            sys.stdout.flush()
            sys.stderr.flush()
        protocol.write(f"done {task_path}\n")
        protocol.flush()


if __name__ == "__main__":
    if sys.argv[1:] == ["--serve"]:
        serve()
    else:
        run_task(Path(sys.argv[1]))
