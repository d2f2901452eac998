"""Typed results shared by validate, import and export."""

from __future__ import annotations

import json
from dataclasses import dataclass, field

from racer.model_io.codes import ProblemCode


@dataclass(frozen=True)
class ValidationProblem:
    """One reason a model can't be imported: the console code, the file, what is wrong, and how to fix it."""

    code: ProblemCode
    path: str
    """Key relative to the model prefix (e.g. `model/.coach_checkpoint`), or "" for the source as a whole."""
    message: str
    fix: str

    def render(self) -> str:
        where = f"{self.path}: " if self.path else ""
        return f"{self.code.value}  {where}{self.message}\n    fix: {self.fix}"

    def to_json(self) -> dict[str, str]:
        return {"code": self.code.value, "path": self.path, "message": self.message, "fix": self.fix}


@dataclass(frozen=True)
class SizeLimits:
    """File-size limits in bytes.

    * `model_bytes` (MODEL_TAR_FILE_SIZE_LIMIT_EXCEEDED): 1 GiB, the DeepRacer-on-AWS import limit
      ("A model folder exported from DeepRacer (must be under 1GB)", deepracer-on-aws
      `source/docs/import/README.md` @ 15142da1). Applied to a .tar.gz source, to a `model.tar.gz` in the
      prefix, and to the total of the files an import copies.
    * `json_yaml_bytes` (JSON_YAML_FILE_SIZE_LIMIT_EXCEEDED): 10 MiB, the same README ("Your YAML file
      exceeds the 10 MB file size limit"). Real files are a few kB.
    * `checkpoint_file_bytes` (CHECKPOINT_FILE_SIZE_LIMIT_EXCEEDED): 512 MiB per file, **our choice**; no
      number was published. The largest DeepRacer network (stereo DEEP_CONVOLUTIONAL_NETWORK, two towers of
      ~7.2 M parameters) is ~58 MB of fp32 weights, ~175 MB with Adam's two moment tensors, so 512 MiB
      leaves ~3x headroom while catching files that are not checkpoints.
    """

    model_bytes: int = 1 << 30
    checkpoint_file_bytes: int = 512 << 20
    json_yaml_bytes: int = 10 << 20


DEFAULT_LIMITS = SizeLimits()


@dataclass(frozen=True)
class CheckpointSelection:
    """Which checkpoints an import copies and which one the pointer names afterwards (the console's logic)."""

    checkpoints: tuple[str, ...]
    """Checkpoint names (`<N>_Step-<M>.ckpt`), oldest first."""
    pointer: str
    """The name `.coach_checkpoint` holds after import (last checkpoint)."""
    best: str
    """The best checkpoint (= pointer when only .coach_checkpoint was there)."""
    source: str
    """`model/deepracer_checkpoints.json` or `model/.coach_checkpoint`: which file decided."""


@dataclass(frozen=True)
class ImportPlan:
    """What a valid model consists of, as found by validation: keys relative to the model prefix."""

    selection: CheckpointSelection
    checkpoint_files: tuple[str, ...]
    """Every file of the selected checkpoints, plus their `model_<N>.pb` / `model_<N>.onnx` when present."""
    metadata_key: str
    hyperparameters_key: str
    reward_function_key: str
    training_params_key: str
    optional_keys: tuple[str, ...]
    """Copied when present: metrics JSON (`metrics/...`, `TrainingMetrics*.json`, `EvaluationMetrics*.json`) and
    the per-worker `training_params_<i>.yaml` of multi-world runs."""
    deepracer_checkpoints_key: str | None
    total_bytes: int


@dataclass(frozen=True)
class ValidationReport:
    source: str
    problems: tuple[ValidationProblem, ...]
    notes: tuple[str, ...] = ()
    """Things worth knowing that don't stop an import (ignored files, hyperparameter warnings)."""
    plan: ImportPlan | None = field(default=None)
    """Set only when there are no problems."""

    @property
    def ok(self) -> bool:
        return not self.problems

    @property
    def codes(self) -> list[ProblemCode]:
        return [problem.code for problem in self.problems]

    def to_json(self) -> str:
        plan = None
        if self.plan is not None:
            plan = {
                "checkpoints": list(self.plan.selection.checkpoints),
                "best": self.plan.selection.best,
                "pointer": self.plan.selection.pointer,
                "decided_by": self.plan.selection.source,
                "total_bytes": self.plan.total_bytes,
            }
        return json.dumps(
            {
                "source": self.source,
                "ok": self.ok,
                "problems": [problem.to_json() for problem in self.problems],
                "notes": list(self.notes),
                "plan": plan,
            },
            indent=2,
        )
