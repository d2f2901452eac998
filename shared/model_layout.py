"""DeepRacer's model folder: the one place that knows every key of a model prefix and the checkpoint name.

Keys are relative to the model prefix (`SAGEMAKER_SHARED_S3_PREFIX`; deepracer-simapp v5.3.3
`bundle/markov/boto/s3/constants.py`); `ModelLayout(prefix)` joins
them onto a prefix. Everything that reads or writes a model folder (trainer, rollout and evaluation workers, model
import/export/validation, analysis) imports its names from here.

    model/<N>_Step-<M>.ckpt.<part>          checkpoint N after M environment steps; racer's parts below,
                                            TensorFlow's are .index, .data-<i>-of-<K>, .meta
    model/model_<N>.onnx | model_<N>.pb     inference model of checkpoint N (racer: ONNX, DeepRacer: frozen graph)
    model/.coach_checkpoint                 one line: the newest complete checkpoint
    model/.lock                             present only while a checkpoint is being uploaded
    model/deepracer_checkpoints.json        best and last evaluated checkpoint
    model/model_metadata.json               action space, sensors, network (copied verbatim)
    model/network.json                      your own network, when model_metadata.json names one (copied verbatim)
    model/.ready, model/.finished           trainer ready / training ended
    ip/hyperparameters.json, ip/done        resolved hyperparameters; DeepRacer's "trainer is up" marker
    ip/preset.json                          the training preset, when the run has one (copied verbatim)
    reward_function.py
    training_params.yaml                    worker 0's settings; training_params_<i>.yaml for worker i
    training-simtrace/<n>-iteration.csv     one worker (several: <i>/training-simtrace/<n>-iteration.csv)
    metrics/TrainingMetrics.json            worker 0 (worker i: TrainingMetrics_<i>.json)
    metrics/iterations.jsonl                racer's own iteration log
    metrics/evaluation/evaluation-<ts>.json one evaluation's metrics (racer's earlier key
                                            metrics/EvaluationMetrics-<ts>.json is still read)
    evaluation-<ts>/evaluation-simtrace/0-iteration.csv    one evaluation's simtrace; <ts> is 14 digits

These are the keys DeepRacer-for-Cloud's scripts give the SimApp (deepracer-for-cloud 2eb1a1f1
`scripts/training/prepare-config.py`, `scripts/evaluation/prepare-config.py`, `defaults/template-run.env`:
DR_LOCAL_S3_METRICS_PREFIX=<prefix>/metrics) and the SimApp's simtrace postfixes (deepracer-simapp 01f5f015
`bundle/markov/boto/s3/constants.py`, worker folders in `bundle/markov/rollout_worker.py`), so DRfC's tools and
deepracer-utils 1.5.6 (`deepracer/logs/handler.py`, `metrics.py`) open a racer run as one of DRfC's.
"""

from __future__ import annotations

import re
from dataclasses import dataclass

from racer.shared.store import join_key

MODEL_DIR = "model"
COACH_CHECKPOINT = "model/.coach_checkpoint"
LOCK = "model/.lock"
DEEPRACER_CHECKPOINTS = "model/deepracer_checkpoints.json"
MODEL_METADATA = "model/model_metadata.json"
NETWORK = "model/network.json"
"""Your own network (network.json of the custom files), beside model_metadata.json; only when it names one."""
READY = "model/.ready"
FINISHED = "model/.finished"
TF_CHECKPOINT_POINTER = "model/checkpoint"
"""TensorFlow's own pointer file, which some DeepRacer-for-Cloud folders carry beside `.coach_checkpoint`."""
HYPERPARAMETERS = "ip/hyperparameters.json"
PRESET = "ip/preset.json"
"""The custom files' preset.json (racer.trainer.preset), verbatim, when the run has one."""
IP_DONE = "ip/done"
REWARD_FUNCTION = "reward_function.py"
TRAINING_PARAMS = "training_params.yaml"
CAR_BUNDLE = "model.tar.gz"
ITERATIONS_LOG = "metrics/iterations.jsonl"
"""racer's own: one JSON line per training iteration (what `racer train` prints), for plots and the live view."""

# The parts racer's CheckpointStore writes after `<N>_Step-<M>.ckpt` (the manifest last).
WEIGHTS_SUFFIX = ".weights.safetensors"
OPTIMIZER_TENSORS_SUFFIX = ".optimizer.safetensors"
OPTIMIZER_SCALARS_SUFFIX = ".optimizer.json"
MANIFEST_SUFFIX = ".json"
RACER_CHECKPOINT_SUFFIXES = (WEIGHTS_SUFFIX, MANIFEST_SUFFIX, OPTIMIZER_TENSORS_SUFFIX, OPTIMIZER_SCALARS_SUFFIX)

_CHECKPOINT_NAME = re.compile(r"^(?P<number>\d+)_Step-(?P<env_steps>\d+)\.ckpt$")
_INFERENCE_MODEL = re.compile(r"^model_(?P<number>\d+)\.(?P<ext>pb|onnx)$")


@dataclass(frozen=True, order=True)
class CheckpointName:
    """`<number>_Step-<env_steps>.ckpt`: checkpoint `number` (from 0) after `env_steps` environment steps."""

    number: int
    env_steps: int

    @property
    def name(self) -> str:
        return f"{self.number}_Step-{self.env_steps}.ckpt"

    def __str__(self) -> str:
        return self.name

    @classmethod
    def parse(cls, text: str) -> CheckpointName:
        """`13_Step-25173.ckpt` -> CheckpointName(13, 25173); ValueError for anything else."""
        found = cls.find(text)
        if found is None:
            raise ValueError(f"{text!r} is not a checkpoint name like 13_Step-25173.ckpt")
        return found

    @classmethod
    def find(cls, text: str) -> CheckpointName | None:
        """Like `parse`, but None for a text that is not a checkpoint name."""
        match = _CHECKPOINT_NAME.match(text)
        if match is None:
            return None
        return cls(int(match["number"]), int(match["env_steps"]))

    @classmethod
    def of_file(cls, file_name: str) -> CheckpointName | None:
        """The checkpoint a file in `model/` belongs to (`3_Step-124.ckpt.index` -> 3_Step-124.ckpt), else None."""
        head, separator, _ = file_name.partition(".ckpt.")
        return cls.find(head + ".ckpt") if separator else None

    def file(self, suffix: str) -> str:
        """`model/<name><suffix>`, e.g. suffix `.index` or WEIGHTS_SUFFIX."""
        return f"{MODEL_DIR}/{self.name}{suffix}"

    def inference_model(self, ext: str) -> str:
        return inference_model(self.number, ext)


def checkpoint_name(number: int, env_steps: int) -> str:
    return CheckpointName(number, env_steps).name


def parse_coach_checkpoint(data: bytes) -> str:
    """The one name in `.coach_checkpoint`; ValueError if the file is not one line of text."""
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError:
        raise ValueError("is not UTF-8 text") from None
    lines = [line.strip() for line in text.splitlines() if line.strip()]
    if len(lines) != 1:
        raise ValueError(f"must hold exactly one line (a checkpoint name), found {len(lines)}")
    return lines[0]


def inference_model(number: int, ext: str) -> str:
    """`model/model_<number>.<ext>`: `onnx` (racer) or `pb` (DeepRacer's frozen graph)."""
    return f"{MODEL_DIR}/model_{number}.{ext}"


def inference_model_number(file_name: str) -> int | None:
    """`model_3.onnx` / `model_3.pb` -> 3, anything else -> None."""
    match = _INFERENCE_MODEL.match(file_name)
    return None if match is None else int(match["number"])


TRAINING_SIMTRACE_DIR = "training-simtrace"
EVALUATION_SIMTRACE_DIR = "evaluation-simtrace"
TRAINING_METRICS_FILE = "TrainingMetrics.json"
_ITERATION_CSV = re.compile(r"^(?P<iteration>\d+)-iteration\.csv$")


def simtrace_iteration(file_name: str) -> int | None:
    """`12-iteration.csv` -> 12 (the simtrace of iteration 12), anything else -> None."""
    match = _ITERATION_CSV.match(file_name)
    return None if match is None else int(match["iteration"])


def droa_training_metrics(name: str) -> str:
    """DeepRacer on AWS's import folder keeps training metrics as `metrics/training/training-<name>.json`."""
    return f"metrics/training/training-{name}.json"


def training_params(worker_id: int) -> str:
    return TRAINING_PARAMS if worker_id == 0 else f"training_params_{worker_id}.yaml"


def training_simtrace(worker_id: int, iteration: int, num_workers: int) -> str:
    """DeepRacer-for-Cloud's layout: one worker writes at the root, several under `<worker>/`."""
    name = f"{TRAINING_SIMTRACE_DIR}/{iteration}-iteration.csv"
    return f"{worker_id}/{name}" if num_workers > 1 else name


def training_metrics(worker_id: int) -> str:
    return f"metrics/{TRAINING_METRICS_FILE}" if worker_id == 0 else f"metrics/TrainingMetrics_{worker_id}.json"


EVALUATION_PREFIX = "evaluation-"
EVALUATION_TIMESTAMP_FORMAT = "%Y%m%d%H%M%S"
"""`<ts>`: 14 digits, as DRfC's evaluation prepare-config.py writes it; deepracer-utils 1.5.6 finds an evaluation's
simtrace only under `evaluation-<14 digits>/` (`evaluation-([0-9]{14})` in `deepracer/logs/handler.py`)."""
EVALUATION_METRICS_DIR = "metrics/evaluation"
_EVALUATION_METRICS = re.compile(r"^metrics/(?:evaluation/evaluation-|EvaluationMetrics-)(?P<timestamp>[^/]+)\.json$")


def evaluation_folder(timestamp: str) -> str:
    """`evaluation-<ts>`: one evaluation's folder under the model prefix."""
    return EVALUATION_PREFIX + timestamp


def evaluation_metrics(timestamp: str) -> str:
    """`metrics/evaluation/evaluation-<ts>.json`, where DRfC's evaluations put their metrics today."""
    return f"{EVALUATION_METRICS_DIR}/{EVALUATION_PREFIX}{timestamp}.json"


def evaluation_metrics_timestamp(relative: str) -> str | None:
    """The `<ts>` of an evaluation metrics key relative to the model prefix, else None. Both forms count: the current
    one and racer's earlier `metrics/EvaluationMetrics-<ts>.json` (DRfC's own until deepracer-for-cloud 59ed9e9,
    March 2024), so that evaluations written before are still found."""
    match = _EVALUATION_METRICS.match(relative)
    return None if match is None else match["timestamp"]


_EVALUATION_FILES = {
    "simtrace": f"{EVALUATION_SIMTRACE_DIR}/0-iteration.csv",
    "summary": "summary.json",
    "params": "evaluation_params.yaml",
    "mcap": "evaluation.mcap",
}


@dataclass(frozen=True)
class EvaluationLayout:
    """Keys of one evaluation, relative to the model prefix (`relative`) and absolute in the store (`key`).

    DeepRacer-for-Cloud's evaluation layout: `metrics/evaluation/evaluation-<ts>.json` (METRICS_S3_OBJECT_KEY in
    deepracer-for-cloud 2eb1a1f1 `scripts/evaluation/prepare-config.py`, under DR_LOCAL_S3_METRICS_PREFIX) and the
    folder `evaluation-<ts>/` with the simtrace (its SIMTRACE_S3_PREFIX); racer keeps its summary, settings, videos
    and recording in the same folder.

    The metrics are written under the current key only, not under racer's earlier `metrics/EvaluationMetrics-<ts>.json`
    as well: no tool needs both (deepracer-utils 1.5.6 reads no evaluation metrics; DRfC's upload and import copy the
    whole `metrics/` prefix), and two copies would count each evaluation twice for anything that lists `metrics/`.
    Readers recognise both (`evaluation_metrics_timestamp`), so evaluations written before still open.
    """

    model_prefix: str
    run_name: str
    """`evaluation-<ts>`; racer's earlier runs may carry a `-<n>` suffix."""

    @property
    def timestamp(self) -> str:
        return self.run_name.removeprefix(EVALUATION_PREFIX)

    def relative(self, name: str) -> str:
        """`metrics`, `simtrace`, `summary`, `params`, `mcap`, or any file name inside the evaluation folder."""
        if name == "metrics":
            return evaluation_metrics(self.timestamp)
        return f"{self.run_name}/{_EVALUATION_FILES.get(name, name)}"

    def video(self, view: str) -> str:
        """DeepRacer's `camera-<view>/<n>-video.mp4` names, inside the evaluation folder."""
        return f"{self.run_name}/{view}/0-video.mp4"

    def key(self, relative: str) -> str:
        return join_key(self.model_prefix, relative)


@dataclass(frozen=True)
class ModelLayout:
    """The keys above under one model prefix in an object store."""

    prefix: str

    def key(self, *parts: str) -> str:
        return join_key(self.prefix, *parts)

    @property
    def model_dir(self) -> str:
        return self.key(MODEL_DIR, "")

    @property
    def coach_checkpoint(self) -> str:
        return self.key(COACH_CHECKPOINT)

    @property
    def lock(self) -> str:
        return self.key(LOCK)

    @property
    def deepracer_checkpoints(self) -> str:
        return self.key(DEEPRACER_CHECKPOINTS)

    @property
    def iterations_log(self) -> str:
        return self.key(ITERATIONS_LOG)

    @property
    def model_metadata(self) -> str:
        return self.key(MODEL_METADATA)

    @property
    def network(self) -> str:
        return self.key(NETWORK)

    @property
    def hyperparameters(self) -> str:
        return self.key(HYPERPARAMETERS)

    @property
    def preset(self) -> str:
        return self.key(PRESET)

    @property
    def ip_done(self) -> str:
        return self.key(IP_DONE)

    @property
    def reward_function(self) -> str:
        return self.key(REWARD_FUNCTION)

    @property
    def ready(self) -> str:
        return self.key(READY)

    @property
    def finished(self) -> str:
        return self.key(FINISHED)

    def checkpoint_file(self, name: CheckpointName | str, suffix: str) -> str:
        name = name if isinstance(name, CheckpointName) else CheckpointName.parse(name)
        return self.key(name.file(suffix))

    def inference_model(self, number: int, ext: str = "onnx") -> str:
        return self.key(inference_model(number, ext))

    def training_params(self, worker_id: int) -> str:
        return self.key(training_params(worker_id))

    def training_simtrace(self, worker_id: int, iteration: int, num_workers: int) -> str:
        return self.key(training_simtrace(worker_id, iteration, num_workers))

    def training_metrics(self, worker_id: int) -> str:
        return self.key(training_metrics(worker_id))

    def evaluation(self, run_name: str) -> EvaluationLayout:
        return EvaluationLayout(self.prefix, run_name)
