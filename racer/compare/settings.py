"""A run's settings as one flat table, and which of them differ between runs.

The settings are the files a run keeps in its model folder (racer.shared.model_layout): worker 0's
`training_params.yaml` (other workers' files only where they differ from worker 0's), `ip/hyperparameters.json`,
`model/model_metadata.json` and `reward_function.py` (by content: a hash and its length; the page shows the code),
plus the stop condition the trainer recorded (racer.shared.run_progress). The keys that only say where a run keeps
its files (its prefix, bucket, metrics and simtrace keys) differ between any two runs and are left out.

A file that cannot be read becomes a note naming the file and why; its rows are then missing from that run.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

from racer.shared.deepracer.training_params import TrainingParamsError, parse_training_params
from racer.shared.model_layout import ModelLayout, training_params
from racer.shared.store import ObjectNotFoundError, ObjectStore

RUN_LOCATION_KEYS = frozenset(
    {
        "SAGEMAKER_SHARED_S3_PREFIX",
        "SAGEMAKER_SHARED_S3_BUCKET",
        "METRICS_S3_BUCKET",
        "METRICS_S3_OBJECT_KEY",
        "SIMTRACE_S3_BUCKET",
        "SIMTRACE_S3_PREFIX",
        "MP4_S3_BUCKET",
        "MP4_S3_OBJECT_PREFIX",
        "MODEL_METADATA_FILE_S3_KEY",
        "REWARD_FILE_S3_KEY",
        "TRAINING_JOB_ARN",
        "KINESIS_VIDEO_STREAM_NAME",
        "ROBOMAKER_SIMULATION_JOB_ACCOUNT_ID",
    }
)
"""training_params keys that name the run's own storage and job (the SimApp's sample and DRfC's template write
them; deepracer-simapp v5.3.3 `bundle/markov/boto/s3/constants.py` reads them): never a choice that changes training."""

MISSING = None


@dataclass(frozen=True)
class RunSettings:
    values: Mapping[str, str]
    """`<file>: <key>` -> the value as text, in the files' order."""
    reward_function: str | None = None
    """The reward function's source, when the run has one."""
    notes: tuple[str, ...] = field(default_factory=tuple)


def _text(value: object) -> str:
    """A JSON value as people read it in a table: strings bare, numbers as written, lists and objects compact."""
    if isinstance(value, str):
        return value
    if isinstance(value, bool):
        return "true" if value else "false"
    if value is None:
        return "null"
    if isinstance(value, (int, float)):
        return repr(value)
    return json.dumps(value, separators=(", ", ": "))


def _number(value: object) -> str:
    return f"{value:g}" if isinstance(value, (int, float)) and not isinstance(value, bool) else _text(value)


def describe_action_space(actions: object) -> str:
    """`3 actions: -30° 1 m/s; 0° 1 m/s; 30° 1 m/s` (discrete) or `steering -30..30°, speed 0.5..4 m/s`
    (continuous, DeepRacer's low/high form); anything else as compact JSON."""
    if isinstance(actions, list) and all(
        isinstance(a, dict) and "steering_angle" in a and "speed" in a for a in actions
    ):
        listed = "; ".join(f"{_number(a['steering_angle'])}° {_number(a['speed'])} m/s" for a in actions)
        return f"{len(actions)} actions: {listed}"
    if isinstance(actions, dict) and all(isinstance(actions.get(k), dict) for k in ("steering_angle", "speed")):
        steer, speed = actions["steering_angle"], actions["speed"]
        return (
            f"steering {_number(steer.get('low'))}..{_number(steer.get('high'))}°, "
            f"speed {_number(speed.get('low'))}..{_number(speed.get('high'))} m/s"
        )
    return _text(actions)


def _json_object(store: ObjectStore, key: str, notes: list[str]) -> dict | None:
    try:
        data = store.get_bytes(key)
    except ObjectNotFoundError:
        return None
    try:
        value = json.loads(data.decode("utf-8-sig"))
    except UnicodeDecodeError:
        notes.append(f"{key}: not UTF-8 text; its settings are left out")
        return None
    except json.JSONDecodeError as error:
        notes.append(f"{key}: not JSON ({error.msg} at line {error.lineno}, column {error.colno}); left out")
        return None
    if not isinstance(value, dict):
        notes.append(f"{key}: expected a JSON object, found {type(value).__name__}; left out")
        return None
    return value


def _training_params(store: ObjectStore, layout: ModelLayout, notes: list[str]) -> dict[str, str] | None:
    key = layout.training_params(0)
    try:
        data = store.get_bytes(key)
    except ObjectNotFoundError:
        return None
    try:
        params = parse_training_params(data.decode("utf-8-sig"), key)
    except UnicodeDecodeError:
        notes.append(f"{key}: not UTF-8 text; its settings are left out")
        return None
    except TrainingParamsError as error:
        notes.append(f"{error}; its settings are left out")
        return None
    return {k: ", ".join(v) if isinstance(v, tuple) else v for k, v in params.values.items()}


def read_run_settings(
    store: ObjectStore,
    prefix: str,
    worker_params: Mapping[int, Mapping[str, str]] | None = None,
    stop_condition: Mapping[str, object] | None = None,
) -> RunSettings:
    """The settings of the run under `prefix`; `worker_params` are the other workers' params (RunReader's
    `worker_params`), `stop_condition` the newest iteration's `progress`, when the run has them."""
    worker_params = worker_params or {}
    layout = ModelLayout(prefix)
    notes: list[str] = []
    values: dict[str, str] = {}
    worker0 = _training_params(store, layout, notes)
    name0 = training_params(0)
    for key, value in (worker0 or {}).items():
        if key not in RUN_LOCATION_KEYS:
            values[f"{name0}: {key}"] = value
    for worker_id in sorted(worker_params):
        if worker_id == 0:
            continue
        for key, value in worker_params[worker_id].items():
            if key not in RUN_LOCATION_KEYS and (worker0 or {}).get(key) != value:
                values[f"{training_params(worker_id)}: {key}"] = value
    hyperparameters = _json_object(store, layout.hyperparameters, notes)
    for key, value in (hyperparameters or {}).items():
        values[f"hyperparameters.json: {key}"] = _text(value)
    metadata = _json_object(store, layout.model_metadata, notes)
    for key, value in (metadata or {}).items():
        shown = describe_action_space(value) if key == "action_space" else _text(value)
        values[f"model_metadata.json: {key}"] = shown
    reward = _reward_function(store, layout, notes)
    if reward is not None:
        digest = hashlib.sha256(reward.encode()).hexdigest()[:12]
        values["reward_function.py"] = f"sha256 {digest}…, {len(reward.splitlines())} lines"
    if stop_condition:
        values["stop: max episodes"] = _text(stop_condition.get("max_episodes"))
        minutes = stop_condition.get("max_minutes")
        values["stop: max minutes"] = "none" if minutes is None else _number(minutes)
    return RunSettings(values=values, reward_function=reward, notes=tuple(notes))


def _reward_function(store: ObjectStore, layout: ModelLayout, notes: list[str]) -> str | None:
    try:
        data = store.get_bytes(layout.reward_function)
    except ObjectNotFoundError:
        return None
    try:
        return data.decode("utf-8-sig")
    except UnicodeDecodeError:
        notes.append(f"{layout.reward_function}: not UTF-8 text; left out")
        return None


@dataclass(frozen=True)
class SettingRow:
    name: str
    values: tuple[str | None, ...]
    """One per run, in the runs' order; None where a run has no such setting."""

    @property
    def differs(self) -> bool:
        return len(set(self.values)) > 1


def settings_table(runs: Sequence[Mapping[str, str]]) -> list[SettingRow]:
    """Every setting any run has (in the order first met), with each run's value; a setting one run lacks differs."""
    names: dict[str, None] = {}
    for values in runs:
        names.update(dict.fromkeys(values))
    return [SettingRow(name, tuple(values.get(name, MISSING) for values in runs)) for name in names]
