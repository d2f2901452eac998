"""Find the simtrace CSVs of a run, wherever they are: a folder, a tar.gz, s3://bucket/prefix or a model prefix.

DeepRacer and its tools scatter simtraces over several layouts (deepracer-utils 262e3fe3 `docs/folder-structures.md`):

| layout | where the CSVs are |
|---|---|
| DRfC, one worker / racer | `<prefix>/training-simtrace/<n>-iteration.csv` |
| DRfC, several workers | `<prefix>/<worker>/training-simtrace/<n>-iteration.csv` |
| console export | `sim-trace/training/training-simtrace/<n>-iteration.csv`, |
|  | `sim-trace/evaluation/<ts>-<id>/evaluation-simtrace/0-iteration.csv` |
| DRfC / racer evaluation | `<prefix>/evaluation-<ts>/evaluation-simtrace/0-iteration.csv` |

Every layout is recognised from the key alone, so the same rules serve folders, archives and buckets. Next to the
CSVs, the params yaml files (they name the track) and worker 0's TrainingMetrics JSON are picked up. A single CSV
or a simulation log (SIM_TRACE_LOG lines) can also be given on its own.
"""

from __future__ import annotations

import re
import tarfile
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path, PurePosixPath

from racer.shared import model_layout
from racer.shared.config import settings_from_env, store_settings_at
from racer.shared.store import ObjectStore, S3Store, open_store

TRAINING = "training"
EVALUATION = "evaluation"

_PARAMS_FILE = re.compile(r"^(training_params.*|eval_params.*|evaluation_params.*)\.ya?ml$")
_EVALUATION_METRICS = re.compile(r"(?:^|/)metrics/(?:evaluation/evaluation-|EvaluationMetrics-)[^/]+\.json$")
"""An evaluation's EvaluationMetrics JSON (racer.shared.model_layout.evaluation_metrics, both forms)."""


def is_evaluation_metrics(key: str) -> bool:
    return _EVALUATION_METRICS.search(key) is not None


def is_training_metrics(key: str) -> bool:
    """Worker 0's TrainingMetrics.json (DRfC, racer) or the console's metrics/training/<job>.json."""
    parts = PurePosixPath(key).parts
    return parts[-1] == model_layout.TRAINING_METRICS_FILE or (
        len(parts) >= 3 and parts[-3:-1] == ("metrics", "training") and parts[-1].endswith(".json")
    )


class SourceError(Exception):
    """The source does not exist or holds no simtrace CSV; the message says what was looked at."""


@dataclass(frozen=True)
class SimtraceFile:
    """One simtrace CSV and where it sits in the run."""

    name: str
    """Where the file came from (path, archive member or s3 URL), used in every error message."""
    phase: str
    """`training` or `evaluation`."""
    run: str
    """The folder that identifies one evaluation (or one training run when several are side by side)."""
    worker: int
    iteration: int
    read_bytes: Callable[[], bytes]
    from_log: bool = False
    """The bytes are a robomaker log with SIM_TRACE_LOG lines, not a CSV."""


@dataclass(frozen=True)
class SimtraceFiles:
    """A run's simtrace CSVs and the files found beside them, from any source `open_source` accepts."""

    description: str
    simtraces: list[SimtraceFile]
    params_yaml: dict[str, bytes]
    """training/evaluation params yaml files found next to the simtraces, by name (they name the track)."""
    training_metrics: dict[str, bytes] = field(default_factory=dict)
    """Worker 0's TrainingMetrics JSON files, by name (they hold the in-training evaluations)."""
    evaluation_metrics: dict[str, bytes] = field(default_factory=dict)
    """EvaluationMetrics JSON files of `racer evaluate` / DRfC evaluations, by name (their lap times count from the
    reset, racer.analysis.evaluation_times)."""


def classify(key: str) -> tuple[str, str, int, int] | None:
    """(phase, run, worker, iteration) for a simtrace key in any known layout, None for other files."""
    parts = PurePosixPath(key).parts
    iteration = model_layout.simtrace_iteration(parts[-1]) if parts else None
    if iteration is None:
        return None
    folder = parts[-2] if len(parts) >= 2 else ""
    if folder == model_layout.TRAINING_SIMTRACE_DIR:
        phase = TRAINING
    elif folder == model_layout.EVALUATION_SIMTRACE_DIR:
        phase = EVALUATION
    else:
        return None
    above = list(parts[:-2])
    worker = 0
    if phase == TRAINING and above and above[-1].isdigit():
        worker = int(above.pop())
    if phase == TRAINING and above[-2:] == ["sim-trace", "training"]:
        above = above[:-2]
    run = "/".join(above) if above else "."
    return phase, run, worker, iteration


def classify_loose_csv(path: Path) -> tuple[str, str, int, int]:
    """A CSV given on its own: the phase and iteration are guessed from its name (`..._evaluation_0-iteration.csv`)."""
    phase = EVALUATION if "evaluation" in path.name.lower() else TRAINING
    match = re.search(r"(\d+)-iteration\.csv$", path.name)
    return phase, path.stem, 0, int(match.group(1)) if match else 0


def _from_keys(keys: list[str], name_of: Callable[[str], str], read: Callable[[str], bytes]) -> SimtraceFiles:
    simtraces: list[SimtraceFile] = []
    params: dict[str, bytes] = {}
    metrics: dict[str, bytes] = {}
    evaluation_metrics: dict[str, bytes] = {}
    for key in keys:
        found = classify(key)
        if found is not None:
            phase, run, worker, iteration = found
            simtraces.append(
                SimtraceFile(name_of(key), phase, run, worker, iteration, read_bytes=lambda key=key: read(key))
            )
        elif _PARAMS_FILE.match(PurePosixPath(key).name):
            params[name_of(key)] = read(key)
        elif is_training_metrics(key):
            metrics[name_of(key)] = read(key)
        elif is_evaluation_metrics(key):
            evaluation_metrics[name_of(key)] = read(key)
    simtraces.sort(key=lambda f: (f.phase, f.run, f.worker, f.iteration))
    return SimtraceFiles("", simtraces, params, metrics, evaluation_metrics)


def from_folder(folder: Path) -> SimtraceFiles:
    keys = sorted(p.relative_to(folder).as_posix() for p in folder.rglob("*") if p.is_file())
    found = _from_keys(keys, lambda k: str(folder / k), lambda k: (folder / k).read_bytes())
    return replace(found, description=str(folder))


def from_csv(path: Path) -> SimtraceFiles:
    phase, run, worker, iteration = classify("/".join(path.parts[-4:])) or classify_loose_csv(path)
    return SimtraceFiles(str(path), [SimtraceFile(str(path), phase, run, worker, iteration, path.read_bytes)], {})


def from_log(path: Path) -> SimtraceFiles:
    """A simulation log given on its own; iterations are not in the log, so every episode counts as iteration 0."""
    phase = TRAINING if "training" in path.name.lower() else EVALUATION
    file = SimtraceFile(str(path), phase, path.stem, 0, 0, path.read_bytes, from_log=True)
    return SimtraceFiles(str(path), [file], {})


def from_tar(path: Path) -> SimtraceFiles:
    """A console "Download logs" archive or any tar.gz of a model folder; read in memory, nothing is extracted."""
    try:
        with tarfile.open(path, "r:*") as archive:
            contents = {
                member.name.removeprefix("./"): archive.extractfile(member).read()
                for member in archive.getmembers()
                if member.isfile()
                and (
                    classify(member.name) is not None
                    or _PARAMS_FILE.match(PurePosixPath(member.name).name)
                    or is_training_metrics(member.name)
                    or is_evaluation_metrics(member.name)
                )
            }
    except tarfile.TarError as error:
        raise SourceError(f"{path}: not a readable tar archive ({error})") from error
    found = _from_keys(sorted(contents), lambda k: f"{path}!{k}", contents.__getitem__)
    return replace(found, description=str(path))


def store_url(store: ObjectStore, key: str) -> str:
    """How a key is named in messages: s3://bucket/key for S3, the file path for a local store."""
    if isinstance(store, S3Store):
        return f"s3://{store.bucket}/{key}"
    return str(Path(store.describe()) / key)


def from_store(store: ObjectStore, prefix: str) -> SimtraceFiles:
    prefix = prefix.strip("/")
    listed = store.list_keys(f"{prefix}/" if prefix else "")
    relative = [key[len(prefix) + 1 :] if prefix else key for key in listed]
    full_key = lambda k: f"{prefix}/{k}" if prefix else k  # noqa: E731
    found = _from_keys(relative, lambda k: store_url(store, full_key(k)), lambda k: store.get_bytes(full_key(k)))
    return replace(found, description=f"{store_url(store, prefix)} ({store.describe()})")


def open_source(source: str) -> SimtraceFiles:
    """Resolve the command-line SOURCE: an existing path, else s3://bucket/prefix, else a model prefix in RACER_STORE."""
    path = Path(source).expanduser()
    if path.is_dir():
        found = from_folder(path)
    elif path.is_file() and path.suffix == ".csv":
        found = from_csv(path)
    elif path.is_file() and (path.name.endswith((".tar.gz", ".tgz", ".tar"))):
        found = from_tar(path)
    elif path.is_file() and path.suffix == ".log":
        found = from_log(path)
    elif path.exists():
        raise SourceError(f"{source}: expected a folder, a .csv, a .log, a .tar.gz or s3://bucket/prefix")
    elif source.startswith("s3://"):
        bucket, _, prefix = source.removeprefix("s3://").partition("/")
        found = from_store(open_store(store_settings_at(f"s3://{bucket}")), prefix)
    else:
        found = from_store(open_store(settings_from_env().store), source)
    if not found.simtraces:
        raise SourceError(
            f"{found.description}: no simtrace CSV found (looked for */training-simtrace/<n>-iteration.csv and "
            "*/evaluation-simtrace/<n>-iteration.csv)"
        )
    return found
