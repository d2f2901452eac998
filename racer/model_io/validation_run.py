"""What one validation collects while its checks run: problems, notes, and reads that never raise."""

from __future__ import annotations

import json

from racer.model_io.codes import ProblemCode
from racer.model_io.problems import ValidationProblem
from racer.model_io.source_errors import SOURCE_ERRORS
from racer.model_io.source_problems import problem_for_source_error
from racer.model_io.sources import ModelSource
from racer.shared.store import ObjectNotFoundError

CHECKPOINT_FIX = (
    "restore the missing files from your copy of the model, or point model/.coach_checkpoint "
    "(and model/deepracer_checkpoints.json) at a checkpoint whose files are all present"
)


class ValidationRun:
    """Accumulates problems and notes while the checks run, and reads files without raising."""

    def __init__(self, source: ModelSource, files: dict[str, int]):
        self.source = source
        self.files = files
        self.problems: list[ValidationProblem] = []
        self.notes: list[str] = []
        self.oversized: set[str] = set()
        self.cut_off = False
        """Set after the source refused a read for a reason other than a missing file: one problem is enough."""

    def add(self, code: ProblemCode, path: str, message: str, fix: str) -> None:
        self.problems.append(ValidationProblem(code, path, message, fix))

    def read(self, key: str) -> bytes | None:
        """The file's bytes, or None (with a problem recorded) if it is too big or can't be read."""
        if key in self.oversized or self.cut_off:
            return None
        try:
            return self.source.read(key)
        except SOURCE_ERRORS as error:
            self.problems.append(problem_for_source_error(error, self.source.describe(), key))
            self.cut_off = not isinstance(error, ObjectNotFoundError | FileNotFoundError)
            return None


def decode_json(data: bytes, key: str) -> object:
    """JSON with the byte-order mark some editors add; ValueError naming line and column."""
    try:
        return json.loads(data.decode("utf-8-sig"))
    except UnicodeDecodeError as error:
        raise ValueError(f"{key}: not UTF-8 text (byte {error.start})") from None
    except json.JSONDecodeError as error:
        raise ValueError(f"{key}: invalid JSON at line {error.lineno}, column {error.colno}: {error.msg}") from None
