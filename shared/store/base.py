"""The object-store seam: the same key layout on S3/MinIO and in a local directory.

Keys are DeepRacer's (`<prefix>/model/.coach_checkpoint`, `<prefix>/ip/hyperparameters.json`, ...),
always with `/` separators and never starting with `/`.
"""

from __future__ import annotations

from typing import Protocol


class StoreError(Exception):
    """Base class for object-store failures; messages name the store location and the key."""


class ObjectNotFoundError(StoreError):
    def __init__(self, location: str, key: str):
        super().__init__(f"{location}: no object at key {key!r}")
        self.location = location
        self.key = key


class StoreUnavailableError(StoreError):
    """The store could not be reached within the time budget."""


class BucketNotFoundError(StoreError):
    def __init__(self, bucket: str, endpoint: str):
        super().__init__(f"bucket {bucket!r} does not exist at {endpoint}")
        self.bucket = bucket


class AccessDeniedError(StoreError):
    def __init__(self, location: str, key: str, operation: str):
        super().__init__(f"{location}: access denied for {operation} on {key!r}")
        self.location = location
        self.key = key


class ObjectStore(Protocol):
    """What every part of the system may ask of a store."""

    def describe(self) -> str:
        """A human-readable location, e.g. `s3://bucket (http://127.0.0.1:9000)` or a directory path."""
        ...

    def put_bytes(self, key: str, data: bytes) -> None:
        """Create or overwrite one object. Readers see either the old or the new content, never a part."""
        ...

    def get_bytes(self, key: str) -> bytes:
        """Raises ObjectNotFoundError if the key does not exist."""
        ...

    def list_keys(self, prefix: str) -> list[str]:
        """All keys starting with `prefix` (a plain string prefix, as S3's), sorted."""
        ...

    def delete(self, key: str) -> None:
        """Remove an object; deleting a missing key is not an error."""
        ...

    def exists(self, key: str) -> bool: ...

    def size(self, key: str) -> int:
        """Size in bytes; raises ObjectNotFoundError if missing."""
        ...


def validate_key(key: str) -> str:
    if not key or key.startswith("/") or "\\" in key or any(part in {"", ".", ".."} for part in key.split("/")):
        raise ValueError(f"invalid object key {key!r}: use relative 'a/b/c' keys without empty, '.' or '..' parts")
    return key


def join_key(*parts: str) -> str:
    """Join key parts with '/', ignoring empty parts (an empty model prefix is allowed)."""
    return "/".join(part.strip("/") for part in parts if part and part.strip("/"))
