"""Object stores: `open_store(settings)` gives an S3Store or a LocalStore with the same interface."""

from racer.shared.config import LocalStoreSettings, S3Settings, StoreSettings
from racer.shared.store.base import (
    AccessDeniedError,
    BucketNotFoundError,
    ObjectNotFoundError,
    ObjectStore,
    StoreError,
    StoreUnavailableError,
    join_key,
)
from racer.shared.store.local import LocalStore
from racer.shared.store.s3 import S3Store


def open_store(settings: StoreSettings) -> ObjectStore:
    if isinstance(settings, S3Settings):
        return S3Store(settings)
    if isinstance(settings, LocalStoreSettings):
        return LocalStore(settings.root)
    raise TypeError(f"unknown store settings {settings!r}")


__all__ = [
    "AccessDeniedError",
    "BucketNotFoundError",
    "LocalStore",
    "ObjectNotFoundError",
    "ObjectStore",
    "S3Store",
    "StoreError",
    "StoreUnavailableError",
    "join_key",
    "open_store",
]
