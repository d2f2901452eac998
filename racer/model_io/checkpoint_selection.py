"""The console importer's choice of checkpoints: `model/deepracer_checkpoints.json` first (best and last), else
`model/.coach_checkpoint` (the named checkpoint and the one before it), each checked for complete files."""

from __future__ import annotations

from racer.model_io import checkpoints as ck
from racer.model_io.codes import ProblemCode
from racer.model_io.problems import CheckpointSelection
from racer.model_io.validation_run import CHECKPOINT_FIX, ValidationRun
from racer.shared import model_layout
from racer.shared.model_layout import CheckpointName
from racer.shared.policy.best_and_last import parse_best_and_last_names


def select_checkpoints(run: ValidationRun) -> CheckpointSelection | None:
    """The console's order: deepracer_checkpoints.json, then .coach_checkpoint, else the model can't be imported."""
    if model_layout.DEEPRACER_CHECKPOINTS in run.files:
        selection = _select_from_deepracer_checkpoints(run)
        if selection is not None and model_layout.COACH_CHECKPOINT in run.files:
            coach = run.read(model_layout.COACH_CHECKPOINT)
            if coach is not None and coach.decode("utf-8", "replace").strip() != selection.pointer:
                run.notes.append(
                    f"{model_layout.COACH_CHECKPOINT} ignored: {model_layout.DEEPRACER_CHECKPOINTS} takes precedence "
                    f"(as in the console); after import the pointer names {selection.pointer}"
                )
        return selection
    if model_layout.COACH_CHECKPOINT in run.files:
        return _select_from_coach_checkpoint(run)
    newest = [name for name in ck.all_checkpoint_names(run.files) if not ck.missing_parts(name, run.files)]
    hint = f" (the newest complete one here is {newest[-1]})" if newest else ""
    if model_layout.TF_CHECKPOINT_POINTER in run.files:
        hint += (
            f"; {model_layout.TF_CHECKPOINT_POINTER} is TensorFlow's own pointer (models older than SimApp 2.0 had only that): "
            "its model_checkpoint_path names the checkpoint to write there"
        )
    run.add(
        ProblemCode.COACH_CHECKPOINT_DOES_NOT_EXIST,
        model_layout.COACH_CHECKPOINT,
        f"neither {model_layout.DEEPRACER_CHECKPOINTS} nor {model_layout.COACH_CHECKPOINT} exists, so no checkpoint is named",
        f"restore model/.coach_checkpoint: one line holding the checkpoint name, e.g. 13_Step-25173.ckpt{hint}",
    )
    return None


def _named_checkpoint(run: ValidationRun, pointer_key: str, field: str, text: str) -> CheckpointName | None:
    name = CheckpointName.find(text)
    if name is None:
        run.add(
            ProblemCode.MODEL_VALIDATION_SERVICE_ERROR,
            pointer_key,
            f"{field}: {text!r} does not follow the naming convention <N>_Step-<M>.ckpt",
            "restore the original pointer file; it names a checkpoint like 13_Step-25173.ckpt",
        )
    return name


def _present_checkpoints(run: ValidationRun) -> str:
    names = ck.all_checkpoint_names(run.files)
    return f" (checkpoints here: {', '.join(map(str, names))})" if names else " (no checkpoint files at all)"


def _require_complete(run: ValidationRun, pointer_key: str, name: CheckpointName) -> bool:
    missing = ck.missing_parts(name, run.files)
    if missing:
        run.add(
            ProblemCode.CHECKPOINT_FILES_DOES_NOT_EXIST,
            pointer_key,
            f"names checkpoint {name}, but these files are missing: {', '.join(missing)}{_present_checkpoints(run)}",
            CHECKPOINT_FIX,
        )
    return not missing


def _select_from_deepracer_checkpoints(run: ValidationRun) -> CheckpointSelection | None:
    data = run.read(model_layout.DEEPRACER_CHECKPOINTS)
    if data is None:
        return None
    try:
        pointers = parse_best_and_last_names(data)
    except ValueError as error:
        run.add(
            ProblemCode.MODEL_VALIDATION_SERVICE_ERROR,
            model_layout.DEEPRACER_CHECKPOINTS,
            str(error),
            'restore the original file: {"best_checkpoint": {"name": "<N>_Step-<M>.ckpt", ...}, '
            '"last_checkpoint": {"name": ...}}, or delete it to fall back to model/.coach_checkpoint',
        )
        return None
    best = _named_checkpoint(run, model_layout.DEEPRACER_CHECKPOINTS, "best_checkpoint.name", pointers.best)
    last = _named_checkpoint(run, model_layout.DEEPRACER_CHECKPOINTS, "last_checkpoint.name", pointers.last)
    if best is None or last is None:
        return None
    missing = {name: ck.missing_parts(name, run.files) for name in sorted({best, last})}
    if any(missing.values()):
        described = "; ".join(f"{name}: {', '.join(parts)}" for name, parts in missing.items() if parts)
        run.add(
            ProblemCode.CHECKPOINT_FILES_DOES_NOT_EXIST,
            model_layout.DEEPRACER_CHECKPOINTS,
            f"names best {best} and last {last}, but files are missing ({described}){_present_checkpoints(run)}",
            CHECKPOINT_FIX,
        )
        return None
    return CheckpointSelection(
        checkpoints=tuple(name.name for name in sorted({best, last})),
        pointer=last.name,
        best=best.name,
        source=model_layout.DEEPRACER_CHECKPOINTS,
    )


def _select_from_coach_checkpoint(run: ValidationRun) -> CheckpointSelection | None:
    data = run.read(model_layout.COACH_CHECKPOINT)
    if data is None:
        return None
    try:
        text = model_layout.parse_coach_checkpoint(data)
    except ValueError as error:
        run.add(
            ProblemCode.MODEL_VALIDATION_SERVICE_ERROR,
            model_layout.COACH_CHECKPOINT,
            str(error),
            "restore the original file: one line holding the checkpoint name, e.g. 13_Step-25173.ckpt",
        )
        return None
    name = _named_checkpoint(run, model_layout.COACH_CHECKPOINT, "checkpoint name", text)
    if name is None or not _require_complete(run, model_layout.COACH_CHECKPOINT, name):
        return None
    previous = ck.previous_checkpoint(name, run.files)
    chosen = (previous, name) if previous is not None else (name,)
    if previous is None:
        run.notes.append(
            f"{model_layout.COACH_CHECKPOINT}: no complete checkpoint before {name}; only {name} is imported"
        )
    return CheckpointSelection(
        checkpoints=tuple(item.name for item in chosen),
        pointer=name.name,
        best=name.name,
        source=model_layout.COACH_CHECKPOINT,
    )
