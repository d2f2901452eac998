"""What can go wrong reading a model source (racer.model_io.sources, zip_source): racer's own two errors, and the one
tuple of every error a source's listing or read may raise, which source_problems.problem_for_source_error translates
into the console's import error code."""

from __future__ import annotations

import botocore.exceptions

from racer.shared.store import AccessDeniedError, BucketNotFoundError, ObjectNotFoundError, StoreUnavailableError

__all__ = ["SOURCE_ERRORS", "SourceFormatError", "SourceMissingError"]


class SourceMissingError(Exception):
    """The folder or archive given on the command line does not exist."""


class SourceFormatError(Exception):
    """The archive can't be read as a model (not a tar, unsafe member paths)."""


SOURCE_ERRORS: tuple[type[BaseException], ...] = (
    OSError,
    SourceFormatError,
    botocore.exceptions.BotoCoreError,
    botocore.exceptions.ClientError,
    AccessDeniedError,
    BucketNotFoundError,
    ObjectNotFoundError,
    StoreUnavailableError,
)
"""A source that cannot be reached or read, while listing or reading it (an opened source; opening it may also raise
SourceMissingError)."""
