"""A source that cannot be reached or read, translated into the console's import error code with a fix."""

from __future__ import annotations

import botocore.exceptions

from racer.model_io.codes import ProblemCode
from racer.model_io.problems import ValidationProblem
from racer.model_io.source_errors import SourceFormatError, SourceMissingError
from racer.shared.store import AccessDeniedError, BucketNotFoundError, ObjectNotFoundError, StoreUnavailableError

ACCESS_FIX = (
    "give the credentials in use s3:ListBucket and s3:GetObject on the bucket and prefix (bucket policy "
    "or user policy), or use credentials that have them"
)


def problem_for_source_error(error: BaseException, where: str, key: str = "") -> ValidationProblem:
    """Translate a failure to reach or read the source into the console's code for it."""
    if isinstance(error, SourceMissingError):
        return ValidationProblem(
            ProblemCode.FILE_DOES_NOT_EXIST,
            key,
            str(error),
            "check the path; give a model folder, a .tar.gz of one, or s3://bucket/prefix",
        )
    if isinstance(error, SourceFormatError):
        return ValidationProblem(
            ProblemCode.MODEL_VALIDATION_SERVICE_ERROR,
            key,
            str(error),
            "re-create the archive from the model folder: tar czf model.tar.gz -C <folder> .",
        )
    if isinstance(error, BucketNotFoundError):
        return ValidationProblem(
            ProblemCode.SRC_BUCKET_DOES_NOT_EXIST,
            key,
            f"{where}: {error}",
            "check the bucket name and S3_ENDPOINT_URL; if the bucket was deleted, upload "
            "your copy of the model to an existing bucket and validate that location",
        )
    if isinstance(error, AccessDeniedError):
        cause = error.__cause__
        cause_code = (
            cause.response.get("Error", {}).get("Code", "")
            if isinstance(cause, botocore.exceptions.ClientError)
            else ""
        )
        if cause_code == "InvalidAccessKeyId":
            return unknown_credentials(where, key, f"the S3 server does not know the access key in use ({error})")
        return ValidationProblem(ProblemCode.ACCESS_DENIED_TO_BUCKET, key, f"{where}: {error}", ACCESS_FIX)
    if isinstance(error, botocore.exceptions.ClientError):  # straight from boto3 (the source's own listing)
        code = error.response.get("Error", {}).get("Code", "")
        if code == "NoSuchBucket":
            return ValidationProblem(
                ProblemCode.SRC_BUCKET_DOES_NOT_EXIST,
                key,
                f"{where}: the bucket does not exist",
                "check the bucket name and S3_ENDPOINT_URL; if the bucket was deleted, upload "
                "your copy of the model to an existing bucket and validate that location",
            )
        if code == "InvalidAccessKeyId":
            return unknown_credentials(where, key, f"the S3 server does not know the access key in use ({code})")
        if code in {"AccessDenied", "403", "SignatureDoesNotMatch"}:
            return ValidationProblem(
                ProblemCode.ACCESS_DENIED_TO_BUCKET, key, f"{where}: access denied ({code})", ACCESS_FIX
            )
    if isinstance(error, botocore.exceptions.NoCredentialsError):
        return unknown_credentials(where, key, "no S3 credentials were found")
    if isinstance(error, ObjectNotFoundError | FileNotFoundError):
        return ValidationProblem(
            ProblemCode.FILE_DOES_NOT_EXIST,
            key,
            f"{error} (it was deleted while reading)",
            "restore the file and validate again",
        )
    if isinstance(error, StoreUnavailableError | botocore.exceptions.BotoCoreError | botocore.exceptions.ClientError):
        return ValidationProblem(
            ProblemCode.SERVICE_ERROR,
            key,
            f"{where}: {error}",
            "check that the S3 endpoint (S3_ENDPOINT_URL) is up and reachable, then retry",
        )
    if isinstance(error, PermissionError):
        return ValidationProblem(
            ProblemCode.ACCESS_DENIED_TO_BUCKET,
            key,
            f"{where}: {error}",
            "make the model files readable by this user (chmod / chown)",
        )
    return ValidationProblem(ProblemCode.SERVICE_ERROR, key, f"{where}: {error}", "check the file system, then retry")


def unknown_credentials(where: str, key: str, detail: str) -> ValidationProblem:
    return ValidationProblem(
        ProblemCode.ACCOUNT_RESOURCE_DOES_NOT_EXIST,
        key,
        f"{where}: {detail}",
        "set AWS_ACCESS_KEY_ID and AWS_SECRET_ACCESS_KEY to a user that exists on this S3 "
        "server (for MinIO: MINIO_ROOT_USER or a user created with `mc admin user add`)",
    )
