"""The DeepRacer console's model-import error codes, with a plain local fix for each.

The codes and their short titles are the console's ("Speak to me in Human" column of the AWS page
"My AWS DeepRacer reinforcement learning model is failing to import during the service update",
`../shared/seeds/000_*.txt`). The `meaning` and `fix` texts are ours: they describe what the
check means for this system and what to do locally, not the console's buttons.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum


@dataclass(frozen=True)
class CodeInfo:
    title: str
    """The console's short human sentence."""
    meaning: str
    """When this system reports the code."""


class ProblemCode(str, Enum):  # noqa: UP042 (StrEnum would change str() of a member)
    """One console import error code. The value is the code exactly as the console printed it."""

    SERVICE_ERROR = "SERVICE_ERROR"
    SRC_BUCKET_DOES_NOT_EXIST = "SRC_BUCKET_DOES_NOT_EXIST"
    ACCESS_DENIED_TO_BUCKET = "ACCESS_DENIED_TO_BUCKET"
    COACH_CHECKPOINT_DOES_NOT_EXIST = "COACH_CHECKPOINT_DOES_NOT_EXIST"
    MODEL_TAR_FILE_SIZE_LIMIT_EXCEEDED = "MODEL_TAR_FILE_SIZE_LIMIT_EXCEEDED"
    CHECKPOINT_FILE_SIZE_LIMIT_EXCEEDED = "CHECKPOINT_FILE_SIZE_LIMIT_EXCEEDED"
    JSON_YAML_FILE_SIZE_LIMIT_EXCEEDED = "JSON_YAML_FILE_SIZE_LIMIT_EXCEEDED"
    FILE_DOES_NOT_EXIST = "FILE_DOES_NOT_EXIST"
    S3_COPY_ERROR = "S3_COPY_ERROR"
    CHECKPOINT_FILES_DOES_NOT_EXIST = "CHECKPOINT_FILES_DOES_NOT_EXIST"
    MODEL_VALIDATION_SERVICE_ERROR = "MODEL_VALIDATION_SERVICE_ERROR"
    ACCOUNT_RESOURCE_DOES_NOT_EXIST = "ACCOUNT_RESOURCE_DOES_NOT_EXIST"

    @property
    def info(self) -> CodeInfo:
        return CODE_INFO[self]


CODE_INFO: dict[ProblemCode, CodeInfo] = {
    ProblemCode.SERVICE_ERROR: CodeInfo(
        "Model copy error: Retry update.",
        "The source could not be reached at all (S3 endpoint down or unreachable) or answered with a server error.",
    ),
    ProblemCode.SRC_BUCKET_DOES_NOT_EXIST: CodeInfo(
        "Bucket doesn't exist: Import model manually.",
        "The bucket named in s3://bucket/prefix does not exist on the configured S3 endpoint.",
    ),
    ProblemCode.ACCESS_DENIED_TO_BUCKET: CodeInfo(
        "Can't access bucket: Restore bucket permissions.",
        "The S3 server refused to list or read the model with the credentials in use (HTTP 403).",
    ),
    ProblemCode.COACH_CHECKPOINT_DOES_NOT_EXIST: CodeInfo(
        "Coach file doesn't exist: Import model manually.",
        "Neither model/deepracer_checkpoints.json nor model/.coach_checkpoint is there, so no checkpoint is named.",
    ),
    ProblemCode.MODEL_TAR_FILE_SIZE_LIMIT_EXCEEDED: CodeInfo(
        "Model file too large: Import model manually.",
        "The model archive, a model.tar.gz in the prefix, or the total of the files an import copies is over the limit.",
    ),
    ProblemCode.CHECKPOINT_FILE_SIZE_LIMIT_EXCEEDED: CodeInfo(
        "Checkpoint file too large: Import model manually.",
        "One file of a checkpoint (weights, optimiser state, index, graph, inference model) is over the limit.",
    ),
    ProblemCode.JSON_YAML_FILE_SIZE_LIMIT_EXCEEDED: CodeInfo(
        "Metadata file too large: Import model manually.",
        "A JSON or YAML file of the model (metadata, hyperparameters, training params, pointers) is over the limit.",
    ),
    ProblemCode.FILE_DOES_NOT_EXIST: CodeInfo(
        "File doesn't exist: Import model manually.",
        "A required file (or the whole model) is missing.",
    ),
    ProblemCode.S3_COPY_ERROR: CodeInfo(
        "Model copy error: Retry update.",
        "Import or export could not write a file to the destination store.",
    ),
    ProblemCode.CHECKPOINT_FILES_DOES_NOT_EXIST: CodeInfo(
        "Checkpoint doesn't exist: Import model manually.",
        "A checkpoint named by deepracer_checkpoints.json or .coach_checkpoint is missing or has only part of its files.",
    ),
    ProblemCode.MODEL_VALIDATION_SERVICE_ERROR: CodeInfo(
        "Invalid model: Import model manually.",
        "A file is there but its content is not what training wrote (the console called this an edited model).",
    ),
    ProblemCode.ACCOUNT_RESOURCE_DOES_NOT_EXIST: CodeInfo(
        "Missing or incorrect permissions: Reset permissions.",
        "The S3 server does not know the credentials in use (unknown access key, or no credentials at all).",
    ),
}
