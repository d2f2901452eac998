"""Read-only views of a model prefix: a folder, a .tar.gz archive, or `s3://bucket/prefix`.

Validation and import only need "which files, how big, give me the bytes", so every source offers
exactly that, with keys relative to the model prefix (`model/.coach_checkpoint`, `ip/hyperparameters.json`).
Folders are read directly (not through LocalStore, which would create a staging folder inside the
user's model folder).
"""

from __future__ import annotations

import os
import tarfile
from pathlib import Path, PurePosixPath
from typing import Protocol

from racer.model_io.source_errors import SourceFormatError, SourceMissingError
from racer.model_io.zip_source import ZipSource, is_zip
from racer.shared.config import S3Settings, store_settings_at
from racer.shared.store import ObjectStore, S3Store, join_key

TAR_SUFFIXES = (".tar.gz", ".tgz", ".tar")
_LOCAL_STORE_STAGING = ".racer-staging"

__all__ = [
    "FolderSource",
    "ModelSource",
    "SourceFormatError",
    "SourceMissingError",
    "StoreSource",
    "TarSource",
    "ZipSource",
    "open_source",
]


class ModelSource(Protocol):
    def describe(self) -> str:
        """Where the model is, for messages."""
        ...

    def list_files(self) -> dict[str, int]:
        """Every file under the model prefix: relative key -> size in bytes."""
        ...

    def read(self, key: str) -> bytes:
        """The bytes of one file (relative key)."""
        ...


class FolderSource:
    def __init__(self, root: Path):
        self.root = Path(root)
        if not self.root.is_dir():
            raise SourceMissingError(f"{self.root}: no such folder")

    def describe(self) -> str:
        return str(self.root)

    def list_files(self) -> dict[str, int]:
        files: dict[str, int] = {}
        for dirpath, dirnames, filenames in os.walk(self.root):
            if Path(dirpath) == self.root and _LOCAL_STORE_STAGING in dirnames:
                dirnames.remove(_LOCAL_STORE_STAGING)
            for name in filenames:
                path = Path(dirpath) / name
                if path.is_file():
                    files[path.relative_to(self.root).as_posix()] = path.stat().st_size
        return dict(sorted(files.items()))

    def read(self, key: str) -> bytes:
        return (self.root / key).read_bytes()


class TarSource:
    """A model packed as a tar(.gz): the layout at the archive root or inside one top-level folder."""

    def __init__(self, path: Path):
        self.path = Path(path)
        if not self.path.is_file():
            raise SourceMissingError(f"{self.path}: no such file")
        self.archive_bytes = self.path.stat().st_size
        try:
            self._tar = tarfile.open(self.path, mode="r:*")
            members = self._tar.getmembers()
        except (tarfile.TarError, EOFError, OSError) as error:
            raise SourceFormatError(f"{self.path}: not a readable tar or tar.gz archive ({error})") from None
        regular: dict[str, tarfile.TarInfo] = {}
        for member in members:
            name = PurePosixPath(member.name)
            if name.is_absolute() or ".." in name.parts:
                raise SourceFormatError(f"{self.path}: member {member.name!r} has an unsafe path")
            if member.issym() or member.islnk():
                raise SourceFormatError(
                    f"{self.path}: member {member.name!r} is a link; a model holds plain files only"
                )
            if member.isfile():
                regular[name.as_posix()] = member
        self._members = self._strip_wrapper_folder(regular)

    @staticmethod
    def _strip_wrapper_folder(members: dict[str, tarfile.TarInfo]) -> dict[str, tarfile.TarInfo]:
        """`tar czf m.tar.gz my-model/` puts everything under `my-model/`: look through that one folder."""
        tops = {key.split("/", 1)[0] for key in members}
        if len(tops) == 1 and all("/" in key for key in members):
            top = tops.pop() + "/"
            return {key.removeprefix(top): member for key, member in members.items()}
        return members

    def describe(self) -> str:
        return str(self.path)

    def list_files(self) -> dict[str, int]:
        return {key: member.size for key, member in sorted(self._members.items())}

    def read(self, key: str) -> bytes:
        handle = self._tar.extractfile(self._members[key])
        if handle is None:
            raise SourceFormatError(f"{self.path}: member {key!r} has no data")
        return handle.read()


class StoreSource:
    """A model prefix in an object store (S3/MinIO, or this system's own store)."""

    def __init__(self, store: ObjectStore, prefix: str):
        self.store = store
        self.prefix = prefix.strip("/")

    def describe(self) -> str:
        if isinstance(self.store, S3Store):
            return f"s3://{self.store.bucket}/{self.prefix}" if self.prefix else f"s3://{self.store.bucket}"
        return f"{self.store.describe()}/{self.prefix}" if self.prefix else self.store.describe()

    def _key(self, relative: str) -> str:
        return join_key(self.prefix, relative)

    def list_files(self) -> dict[str, int]:
        listing_prefix = self.prefix + "/" if self.prefix else ""
        if isinstance(self.store, S3Store):
            # One paginated listing carries every size; a training prefix can hold thousands of simtrace files,
            # and asking for each size separately would cost a request per file.
            files: dict[str, int] = {}
            paginator = self.store.client.get_paginator("list_objects_v2")
            for page in paginator.paginate(Bucket=self.store.bucket, Prefix=listing_prefix):
                for item in page.get("Contents", []):
                    files[item["Key"].removeprefix(listing_prefix)] = int(item["Size"])
            return dict(sorted(files.items()))
        keys = self.store.list_keys(listing_prefix)
        return {key.removeprefix(listing_prefix): self.store.size(key) for key in keys}

    def read(self, key: str) -> bytes:
        return self.store.get_bytes(self._key(key))


def split_s3_location(location: str) -> tuple[str, str]:
    """`s3://bucket/some/prefix` -> (`bucket`, `some/prefix`)."""
    rest = location.removeprefix("s3://").strip("/")
    bucket, _, prefix = rest.partition("/")
    if not bucket:
        raise ValueError(f"{location!r}: expected s3://<bucket>/<model prefix>")
    return bucket, prefix.strip("/")


def open_source(location: str) -> ModelSource:
    """A folder, a tar(.gz) archive, or `s3://bucket/prefix` (endpoint and credentials from the environment)."""
    if location.startswith("s3://"):
        bucket, prefix = split_s3_location(location)
        settings = store_settings_at(f"s3://{bucket}")
        if not isinstance(settings, S3Settings):
            raise ValueError(f"{location!r}: not an S3 location")
        return StoreSource(S3Store(settings), prefix)
    path = Path(location).expanduser()
    if path.is_dir():
        return FolderSource(path)
    if path.is_file():
        return ZipSource(path) if is_zip(path) else TarSource(path)  # DRoA <= 1.0.9 wrote ZIPs named .tar.gz
    if location.endswith(TAR_SUFFIXES):
        return TarSource(path)
    raise SourceMissingError(f"{location}: no such folder or archive")
