"""Import a validated model into this system's store, and export a stored model in DeepRacer's layout.

Import copies what the console importer copied (AWS DeepRacer developer guide,
`deepracer-troubleshooting-service-migration-errors.md`, "Checkpoint logic"): the
selected checkpoints with their inference graphs, model_metadata.json, hyperparameters, reward function,
training_params.yaml, metrics and deepracer_checkpoints.json; `model/.coach_checkpoint` is written last so
a reader never sees a pointer to a half-copied model.

Export writes the import-ready prefix (ip/, model/, reward_function.py, training_params.yaml, metrics/, and
model_metadata.json + hyperparameters.json also at the root, where DeepRacer-on-AWS's importer looks) plus the
car bundle `model.tar.gz` (racer.model_io.car_bundle). An imported TensorFlow model keeps `agent/model.pb`.
Export writes to a folder, a .tar.gz or a store prefix (racer.model_io.destinations).
"""

from __future__ import annotations

import dataclasses
import re
from collections.abc import Callable
from dataclasses import dataclass

import botocore.exceptions

from racer.model_io import checkpoints as ck
from racer.model_io.car_bundle import car_bundle, car_bundle_member, car_inference_model
from racer.model_io.codes import ProblemCode
from racer.model_io.deepracer_export import (
    EXPORT_LAYOUTS,
    droa_plan,
    droa_targets,
    refuse_for_droa,
    tensorflow_exports,
)
from racer.model_io.destinations import ArchiveDestination, Destination, StoreDestination, read_back
from racer.model_io.problems import DEFAULT_LIMITS, ImportPlan, SizeLimits, ValidationProblem, ValidationReport
from racer.model_io.source_errors import SOURCE_ERRORS
from racer.model_io.source_problems import problem_for_source_error
from racer.model_io.sources import ModelSource, StoreSource
from racer.model_io.validate import CAR_BUNDLE_KEY, validate_model
from racer.shared import model_layout
from racer.shared.model_layout import CheckpointName
from racer.shared.policy.best_and_last import names_to_bytes as best_and_last_names_to_bytes
from racer.shared.store import ObjectStore, StoreError

MODEL_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9-]{0,63}$")
"""The console's rule for model names: 1-64 characters, letters, digits and hyphens."""

METADATA_TARGET = model_layout.MODEL_METADATA
HYPERPARAMETERS_TARGET = model_layout.HYPERPARAMETERS


class ModelExistsError(Exception):
    """Import or export would overwrite a model; pass overwrite=True (--overwrite) to replace it."""


@dataclass(frozen=True)
class ImportExportResult:
    """What import or export did: the files written (keys relative to the destination prefix) or why not."""

    destination: str
    report: ValidationReport
    """Validation of the source (import) or of the stored model being exported."""
    written: tuple[str, ...] = ()
    problems: tuple[ValidationProblem, ...] = ()
    """Copy failures (S3_COPY_ERROR, or source read errors during the copy)."""
    car_bundle_model: str | None = None
    """Export only: the path of the inference model inside model.tar.gz, or None if none was written."""
    check: ValidationReport | None = None
    """Export only: validation of what was written."""

    @property
    def ok(self) -> bool:
        return self.report.ok and not self.problems and (self.check is None or self.check.ok)


class _CopyFailed(Exception):
    def __init__(self, problem: ValidationProblem):
        super().__init__(problem.message)
        self.problem = problem


def _copy_plan(
    source: ModelSource,
    plan: ImportPlan,
    destination: Destination,
    *,
    metadata_targets: tuple[str, ...],
    hyperparameters_targets: tuple[str, ...],
    deepracer_checkpoints: bytes | None,
    car_bundle_from: str | None = None,
    extra_files: dict[str, bytes] | None = None,
    optional_target: Callable[[str], str] = str,
) -> list[str]:
    """Copy the planned files, then `extra_files` (made for the export, e.g. TensorFlow's), then the car bundle
    built from `car_bundle_from` (an inference model key, looked up in extra_files first) if given, then
    `.coach_checkpoint` last. Raises _CopyFailed with the problem on the first failure."""
    extra_files = extra_files or {}
    copies: list[tuple[str, str]] = [(key, key) for key in plan.checkpoint_files]
    copies += [(plan.metadata_key, target) for target in metadata_targets]
    copies += [(plan.hyperparameters_key, target) for target in hyperparameters_targets]
    copies += [
        (plan.reward_function_key, plan.reward_function_key),
        (plan.training_params_key, plan.training_params_key),
    ]
    copies += [(key, optional_target(key)) for key in plan.optional_keys]
    written: list[str] = []

    def read(key: str) -> bytes:
        if key in extra_files:
            return extra_files[key]
        try:
            return source.read(key)
        except SOURCE_ERRORS as error:
            raise _CopyFailed(problem_for_source_error(error, source.describe(), key)) from error

    def put(target: str, data: bytes) -> None:
        try:
            destination.put_bytes(target, data)
        except (StoreError, OSError, botocore.exceptions.BotoCoreError, botocore.exceptions.ClientError) as error:
            raise _CopyFailed(
                ValidationProblem(
                    ProblemCode.S3_COPY_ERROR,
                    target,
                    f"writing to {destination.describe()} failed: {error}",
                    "check that the destination store is reachable and writable (bucket exists, credentials may "
                    "s3:PutObject), then run the command again",
                )
            ) from error
        written.append(target)

    last_read: tuple[str, bytes] | None = None  # the metadata is written twice on export: read it once
    for source_key, target in copies:
        if last_read is None or last_read[0] != source_key:
            last_read = (source_key, read(source_key))
        put(target, last_read[1])
    for key, data in extra_files.items():
        put(key, data)
    if deepracer_checkpoints is not None:
        put(model_layout.DEEPRACER_CHECKPOINTS, deepracer_checkpoints)
    if car_bundle_from is not None:
        put(CAR_BUNDLE_KEY, car_bundle(read(plan.metadata_key), car_bundle_from, read(car_bundle_from))[0])
    put(model_layout.COACH_CHECKPOINT, plan.selection.pointer.encode())
    return written


def _source_deepracer_checkpoints(source: ModelSource, plan: ImportPlan) -> bytes:
    """The source's own file when it had one (keeps avg_eval_metric); otherwise one naming the pointer as both."""
    if plan.deepracer_checkpoints_key is not None:
        return source.read(plan.deepracer_checkpoints_key)
    pointer = CheckpointName.parse(plan.selection.pointer)
    assert pointer is not None  # validation accepted it
    return best_and_last_names_to_bytes(pointer, pointer)


def import_model(
    source: ModelSource,
    store: ObjectStore,
    model_name: str,
    *,
    overwrite: bool = False,
    limits: SizeLimits = DEFAULT_LIMITS,
) -> ImportExportResult:
    """Validate `source` and copy it to `<model_name>/` in `store` with the console's checkpoint logic."""
    if not MODEL_NAME.match(model_name):
        raise ValueError(
            f"model name {model_name!r}: use 1-64 letters, digits and hyphens, starting with a letter "
            "or digit (the console's rule)"
        )
    destination = StoreDestination(store, model_name)
    report = validate_model(source, limits)
    if report.plan is None:
        return ImportExportResult(destination.describe(), report)
    try:
        existing = store.list_keys(model_name + "/")
        if existing and not overwrite:
            raise ModelExistsError(
                f"{destination.describe()} already holds a model ({len(existing)} files); "
                "choose another name or pass --overwrite"
            )
        for key in existing:
            store.delete(key)
    except (StoreError, botocore.exceptions.BotoCoreError, botocore.exceptions.ClientError) as error:
        return ImportExportResult(
            destination.describe(),
            report,
            problems=(
                ValidationProblem(
                    ProblemCode.S3_COPY_ERROR,
                    "",
                    f"can't prepare {destination.describe()}: {error}",
                    "check that the destination store is reachable, the bucket exists and the credentials may list, "
                    "write and delete there",
                ),
            ),
        )
    try:
        deepracer_checkpoints = (
            source.read(report.plan.deepracer_checkpoints_key) if report.plan.deepracer_checkpoints_key else None
        )
        written = _copy_plan(
            source,
            report.plan,
            destination,
            metadata_targets=(METADATA_TARGET,),
            hyperparameters_targets=(HYPERPARAMETERS_TARGET,),
            deepracer_checkpoints=deepracer_checkpoints,
        )
    except _CopyFailed as failure:
        _remove_partial(store, model_name)
        return ImportExportResult(destination.describe(), report, problems=(failure.problem,))
    except SOURCE_ERRORS as error:
        _remove_partial(store, model_name)
        return ImportExportResult(
            destination.describe(), report, problems=(problem_for_source_error(error, source.describe()),)
        )
    return ImportExportResult(destination.describe(), report, written=tuple(written))


def _remove_partial(store: ObjectStore, prefix: str) -> None:
    """Best effort: a failed import must not leave a model that looks usable (its pointer was never written)."""
    try:
        for key in store.list_keys(prefix + "/"):
            store.delete(key)
    except (StoreError, botocore.exceptions.BotoCoreError, botocore.exceptions.ClientError):
        return


def export_model(
    store: ObjectStore,
    model_prefix: str,
    destination: Destination,
    *,
    limits: SizeLimits = DEFAULT_LIMITS,
    check: bool = True,
    tensorflow: bool = False,
    layout: str = "racer",
) -> ImportExportResult:
    """Write `model_prefix` from `store` to `destination` in the import-ready layout plus model.tar.gz.

    tensorflow=True adds DeepRacer's TensorFlow files for each racer checkpoint (checkpoint + `model_<N>.pb`) and
    puts the frozen graph in the car bundle as `agent/model.pb` (needs the optional TensorFlow extra).
    layout="droa" writes the folder DeepRacer on AWS imports (TensorFlow files only; implies tensorflow=True)."""
    if layout not in EXPORT_LAYOUTS:
        raise ValueError(f"layout must be one of {', '.join(EXPORT_LAYOUTS)}, got {layout!r}")
    tensorflow = tensorflow or layout == "droa"
    source = StoreSource(store, model_prefix)
    refuse_for_droa(source, layout)
    report = validate_model(source, limits)
    if report.plan is None:
        return ImportExportResult(destination.describe(), report)
    plan = _exported_plan(report.plan)
    extra_files = tensorflow_exports(source, plan, layout) if tensorflow else {}
    metadata_targets, hyperparameters_targets = (
        (METADATA_TARGET, "model_metadata.json"),
        (HYPERPARAMETERS_TARGET, "hyperparameters.json"),
    )
    if layout == "droa":
        plan = droa_plan(plan)
        hyperparameters_targets = ("hyperparameters.json",)
    inference_key = car_inference_model(plan, extra_files, prefer_pb=tensorflow)
    try:
        written = _copy_plan(
            source,
            plan,
            destination,
            metadata_targets=metadata_targets,
            hyperparameters_targets=hyperparameters_targets,
            deepracer_checkpoints=_source_deepracer_checkpoints(source, plan),
            car_bundle_from=inference_key,
            extra_files=extra_files,
            optional_target=droa_targets if layout == "droa" else str,
        )
    except _CopyFailed as failure:
        if isinstance(destination, ArchiveDestination):
            destination.discard()
        return ImportExportResult(destination.describe(), report, problems=(failure.problem,))
    except SOURCE_ERRORS as error:
        if isinstance(destination, ArchiveDestination):
            destination.discard()
        return ImportExportResult(
            destination.describe(), report, problems=(problem_for_source_error(error, source.describe()),)
        )
    if isinstance(destination, ArchiveDestination):
        destination.close()
    checked = validate_model(read_back(destination), limits) if check else None
    car_model = None if inference_key is None else car_bundle_member(inference_key)
    return ImportExportResult(
        destination.describe(), report, written=tuple(written), car_bundle_model=car_model, check=checked
    )


def _exported_plan(plan: ImportPlan) -> ImportPlan:
    """Without deepracer_checkpoints.json export writes one naming the pointer as best and last, so only
    that checkpoint goes out: a later import then copies exactly what was exported."""
    if plan.deepracer_checkpoints_key is not None:
        return plan
    pointer = CheckpointName.parse(plan.selection.pointer)
    assert pointer is not None  # validation accepted it
    files = tuple(
        ck.checkpoint_files(pointer, plan.checkpoint_files) + ck.inference_model_files(pointer, plan.checkpoint_files)
    )
    selection = dataclasses.replace(plan.selection, checkpoints=(pointer.name,))
    return dataclasses.replace(plan, selection=selection, checkpoint_files=files)
