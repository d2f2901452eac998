"""Check a model prefix the way the DeepRacer console importer did, and say what to fix.

Every problem is reported (not just the first), each with the console's code. When there are none the
report carries an ImportPlan: the files an import copies, with the checkpoints the console would choose
(checkpoint_selection.py). Problems collect in a ValidationRun (validation_run.py); a source that cannot be read
becomes the console's code through source_problems.py.
"""

from __future__ import annotations

import ast
import re
from collections.abc import Callable
from pathlib import Path
from typing import TypeVar

import yaml

from racer.model_io import checkpoints as ck
from racer.model_io.checkpoint_selection import select_checkpoints
from racer.model_io.codes import ProblemCode
from racer.model_io.problems import (
    DEFAULT_LIMITS,
    ImportPlan,
    SizeLimits,
    ValidationProblem,
    ValidationReport,
)
from racer.model_io.source_errors import SOURCE_ERRORS
from racer.model_io.source_problems import problem_for_source_error
from racer.model_io.sources import ModelSource, SourceFormatError, SourceMissingError, TarSource, open_source
from racer.model_io.validation_run import ValidationRun, decode_json
from racer.model_io.weight_checks import (
    CAR_BUNDLE_KEY,
    check_car_bundle,
    check_inference_models,
    check_racer_checkpoints,
)
from racer.shared import model_layout
from racer.shared.deepracer.hyperparameters import parse_hyperparameters
from racer.shared.deepracer.model_metadata import ModelMetadata, parse_model_metadata
from racer.shared.model_layout import CheckpointName

METADATA_KEYS = (model_layout.MODEL_METADATA, "model_metadata.json")
"""Trainer layout (deepracer-simapp v5.3.3 `bundle/markov/boto/s3/constants.py`) first, then the prefix root
(DeepRacer-on-AWS export)."""
HYPERPARAMETER_KEYS = (model_layout.HYPERPARAMETERS, "hyperparameters.json")
"""Console / trainer layout first, then the prefix root (DeepRacer-on-AWS export)."""
REWARD_FUNCTION_KEY = model_layout.REWARD_FUNCTION
TRAINING_PARAMS_KEY = model_layout.TRAINING_PARAMS
TF_POINTER_KEY = model_layout.TF_CHECKPOINT_POINTER
_OPTIONAL = re.compile(
    r"^(metrics/.+\.json|(Training|Evaluation)Metrics[^/]*\.json|training_params_\d+\.yaml|model/network\.json)$"
)
"""Metrics the console showed, the per-worker training_params_<i>.yaml of a multi-world run, and your own network
(model/network.json): its frozen graph imports back only with it."""
_WORKER_PARAMS = re.compile(r"^training_params_\d+\.yaml$")

T = TypeVar("T")


def _check_sizes(run: ValidationRun, limits: SizeLimits) -> None:
    for key, size in run.files.items():
        in_model_dir = key.startswith(ck.MODEL_DIR)
        in_checkpoint = in_model_dir and CheckpointName.of_file(key.removeprefix(ck.MODEL_DIR)) is not None
        if in_checkpoint or ck.is_inference_model(key):
            if size > limits.checkpoint_file_bytes:
                run.oversized.add(key)
                run.add(
                    ProblemCode.CHECKPOINT_FILE_SIZE_LIMIT_EXCEEDED,
                    key,
                    f"{size} bytes; the limit for one checkpoint file is {limits.checkpoint_file_bytes} bytes",
                    "this is not a checkpoint DeepRacer or racer writes; restore the file from the training run",
                )
        elif key.endswith((".json", ".yaml", ".yml")) or key == model_layout.COACH_CHECKPOINT:
            if size > limits.json_yaml_bytes:
                run.oversized.add(key)
                run.add(
                    ProblemCode.JSON_YAML_FILE_SIZE_LIMIT_EXCEEDED,
                    key,
                    f"{size} bytes; the limit for a JSON/YAML file is {limits.json_yaml_bytes} bytes",
                    "restore the original file (real ones are a few kB); metrics files can be left out",
                )
        elif key == CAR_BUNDLE_KEY and size > limits.model_bytes:
            run.oversized.add(key)
            run.add(
                ProblemCode.MODEL_TAR_FILE_SIZE_LIMIT_EXCEEDED,
                key,
                f"{size} bytes; the limit for the model archive is {limits.model_bytes} bytes",
                "rebuild model.tar.gz with only model_metadata.json and agent/model.* (racer model export)",
            )


def _check_json_copies(
    run: ValidationRun,
    keys: tuple[str, ...],
    parse: Callable[[object, str], T],
    missing: str,
    fix_missing: str,
    fix_invalid: str,
) -> tuple[str | None, T | None]:
    """A JSON file that may sit in two places (trainer layout, DeepRacer-on-AWS root): each copy present must
    parse, and two copies must hold the same document. Returns the key to use and the parsed value."""
    present = [key for key in keys if key in run.files]
    if not present:
        run.add(ProblemCode.FILE_DOES_NOT_EXIST, keys[0], missing, fix_missing)
        return None, None
    documents: dict[str, object] = {}
    parsed: T | None = None
    for key in present:
        data = run.read(key)
        if data is None:
            continue
        try:
            document = decode_json(data, key)
            value = parse(document, key)
        except ValueError as error:  # ModelMetadataError and HyperparametersError are ValueErrors
            run.add(ProblemCode.MODEL_VALIDATION_SERVICE_ERROR, key, _without_source(str(error), key), fix_invalid)
            continue
        documents[key] = document
        parsed = value if parsed is None else parsed
    if len(documents) == 2 and documents[keys[0]] != documents[keys[1]]:
        run.add(
            ProblemCode.MODEL_VALIDATION_SERVICE_ERROR,
            keys[1],
            f"differs from {keys[0]}; the two copies must describe the same model",
            f"copy {keys[0]} (what the trainer used) over {keys[1]}",
        )
        return present[0], None
    return present[0], parsed


def _check_metadata(run: ValidationRun) -> tuple[str | None, ModelMetadata | None]:
    return _check_json_copies(
        run,
        METADATA_KEYS,
        lambda document, key: parse_model_metadata(document, source=key),
        "neither model/model_metadata.json nor model_metadata.json (prefix root) exists",
        "restore model_metadata.json (action space, sensors, network) from the training run",
        "restore the model_metadata.json the model was trained with; the network's outputs depend on it",
    )


def _without_source(message: str, key: str) -> str:
    """Parser messages start with the file name; the problem already shows it."""
    return message.removeprefix(f"{key}: ")


def _check_hyperparameters(run: ValidationRun) -> str | None:
    key, parsed = _check_json_copies(
        run,
        HYPERPARAMETER_KEYS,
        lambda document, key: parse_hyperparameters(document, source=key),
        "neither ip/hyperparameters.json nor hyperparameters.json (prefix root) exists",
        "restore ip/hyperparameters.json from the training run (or write the hyperparameters you trained with)",
        "restore the original hyperparameters.json; values must be within the console's ranges",
    )
    if parsed is not None:
        run.notes.extend(parsed[1])
    return key


def _check_reward_function(run: ValidationRun) -> None:
    if REWARD_FUNCTION_KEY not in run.files:
        run.add(
            ProblemCode.FILE_DOES_NOT_EXIST,
            REWARD_FUNCTION_KEY,
            "reward_function.py is missing",
            "put the reward function the model was trained with at the prefix root as reward_function.py",
        )
        return
    data = run.read(REWARD_FUNCTION_KEY)
    if data is None:
        return
    try:
        tree = ast.parse(data.decode("utf-8-sig"), filename=REWARD_FUNCTION_KEY)
    except (SyntaxError, UnicodeDecodeError, ValueError) as error:
        run.add(
            ProblemCode.MODEL_VALIDATION_SERVICE_ERROR,
            REWARD_FUNCTION_KEY,
            f"is not valid Python: {error}",
            "restore the reward function file the model was trained with",
        )
        return
    if not any(isinstance(node, ast.FunctionDef) and node.name == "reward_function" for node in tree.body):
        run.add(
            ProblemCode.MODEL_VALIDATION_SERVICE_ERROR,
            REWARD_FUNCTION_KEY,
            "defines no top-level function reward_function(params)",
            "restore the reward function file; DeepRacer calls reward_function(params)",
        )


def _check_training_params(run: ValidationRun) -> None:
    """training_params.yaml (required) and any per-worker training_params_<i>.yaml: YAML mappings."""
    if TRAINING_PARAMS_KEY not in run.files:
        run.add(
            ProblemCode.FILE_DOES_NOT_EXIST,
            TRAINING_PARAMS_KEY,
            "training_params.yaml is missing",
            "restore training_params.yaml (track, race type, ...) at the prefix root",
        )
    for key in sorted(key for key in run.files if key == TRAINING_PARAMS_KEY or _WORKER_PARAMS.match(key)):
        data = run.read(key)
        if data is None:
            continue
        try:
            document = yaml.safe_load(data.decode("utf-8-sig"))
        except (yaml.YAMLError, UnicodeDecodeError) as error:
            run.add(
                ProblemCode.MODEL_VALIDATION_SERVICE_ERROR,
                key,
                f"is not valid YAML: {error}",
                f"restore the original {key}",
            )
            continue
        if not isinstance(document, dict):
            run.add(
                ProblemCode.MODEL_VALIDATION_SERVICE_ERROR,
                key,
                f"must be a YAML mapping of KEY: value, got {type(document).__name__}",
                f"restore the original {key}",
            )


def validate_model(source: ModelSource, limits: SizeLimits = DEFAULT_LIMITS) -> ValidationReport:
    """Run every check on one model prefix; never raises for a bad model, only reports."""
    where = source.describe()
    try:
        files = source.list_files()
    except SOURCE_ERRORS as error:
        return ValidationReport(where, (problem_for_source_error(error, where),))
    if not files:
        return ValidationReport(
            where,
            (
                ValidationProblem(
                    ProblemCode.FILE_DOES_NOT_EXIST,
                    "",
                    f"{where}: there are no files here",
                    "check the prefix (it is the folder holding model/ and ip/); if the model was deleted, upload your copy",
                ),
            ),
        )
    run = ValidationRun(source, files)
    if isinstance(source, TarSource) or hasattr(source, "archive_bytes"):  # a tar or ZIP archive
        unpacked = sum(files.values())
        if source.archive_bytes > limits.model_bytes or unpacked > limits.model_bytes:
            run.add(
                ProblemCode.MODEL_TAR_FILE_SIZE_LIMIT_EXCEEDED,
                "",
                f"archive {source.archive_bytes} bytes, {unpacked} bytes unpacked; the limit is "
                f"{limits.model_bytes} bytes",
                "leave out old checkpoints, videos and simtraces; keep the files "
                "the import needs (racer model export writes exactly those)",
            )
            return ValidationReport(where, tuple(run.problems))
    _check_sizes(run, limits)
    selection = select_checkpoints(run)
    metadata_key, metadata = _check_metadata(run)
    hyperparameters_key = _check_hyperparameters(run)
    _check_reward_function(run)
    _check_training_params(run)
    check_car_bundle(run)
    ignored = sorted(
        {
            key.removeprefix(ck.MODEL_DIR).partition(".ckpt.")[0] + ".ckpt"
            for key in files
            if key.startswith(ck.MODEL_DIR)
            and ".ckpt." in key
            and CheckpointName.of_file(key.removeprefix(ck.MODEL_DIR)) is None
        }
    )
    if ignored:
        run.notes.append(f"ignored (not named <N>_Step-<M>.ckpt): {', '.join(ignored)}")

    plan = None
    if selection is not None:
        names = [CheckpointName.find(name) for name in selection.checkpoints]
        checkpoint_keys = sorted(
            {
                key
                for name in names
                if name
                for key in ck.checkpoint_files(name, files) + ck.inference_model_files(name, files)
            }
        )
        metadata_disagrees = check_racer_checkpoints(run, [name for name in names if name], metadata_key, metadata)
        check_inference_models(run, checkpoint_keys, None if metadata_disagrees else metadata)
        if any(key.endswith(".ckpt.index") for key in checkpoint_keys):
            run.notes.append(
                "TensorFlow checkpoints (DeepRacer / DRoA / DRfC, or racer's export): `racer model "
                "import` converts them to racer checkpoints (with the TensorFlow extra installed)"
            )
        optional = tuple(key for key in files if _OPTIONAL.match(key))
        copied = [
            *checkpoint_keys,
            *optional,
            REWARD_FUNCTION_KEY,
            TRAINING_PARAMS_KEY,
            model_layout.DEEPRACER_CHECKPOINTS,
            *(key for key in (metadata_key, hyperparameters_key) if key),
        ]
        total = sum(files.get(key, 0) for key in set(copied))
        if total > limits.model_bytes:
            run.add(
                ProblemCode.MODEL_TAR_FILE_SIZE_LIMIT_EXCEEDED,
                "",
                f"the files an import copies total {total} bytes; the limit is {limits.model_bytes} bytes",
                "leave out metrics you don't need, or check for checkpoint files that don't belong to the model",
            )
        if not run.problems and metadata_key and hyperparameters_key:
            plan = ImportPlan(
                selection=selection,
                checkpoint_files=tuple(checkpoint_keys),
                metadata_key=metadata_key,
                hyperparameters_key=hyperparameters_key,
                reward_function_key=REWARD_FUNCTION_KEY,
                training_params_key=TRAINING_PARAMS_KEY,
                optional_keys=optional,
                deepracer_checkpoints_key=model_layout.DEEPRACER_CHECKPOINTS
                if model_layout.DEEPRACER_CHECKPOINTS in files
                else None,
                total_bytes=total,
            )
    return ValidationReport(where, tuple(run.problems), tuple(run.notes), plan)


def validate_location(
    location: str, limits: SizeLimits = DEFAULT_LIMITS
) -> tuple[ValidationReport, ModelSource | None]:
    """Open a folder, archive or s3://bucket/prefix and validate it; the source is returned for import."""
    path = Path(location).expanduser()
    if not location.startswith("s3://") and path.is_file() and path.stat().st_size > limits.model_bytes:
        # Checked before opening: listing a tar.gz means decompressing all of it.
        return ValidationReport(
            location,
            (
                ValidationProblem(
                    ProblemCode.MODEL_TAR_FILE_SIZE_LIMIT_EXCEEDED,
                    "",
                    f"archive is {path.stat().st_size} bytes; the limit is {limits.model_bytes} bytes",
                    "leave out old checkpoints, videos and simtraces (racer model export writes only what's needed)",
                ),
            ),
        ), None
    try:
        source = open_source(location)
    except (SourceMissingError, SourceFormatError) as error:
        return ValidationReport(location, (problem_for_source_error(error, location),)), None
    return validate_model(source, limits), source
