"""Where `racer model import|export` write: plain files under a folder, a .tar.gz (DeepRacer-on-AWS's portable
"virtual model" bundle) or a prefix of an object store; each can be read back as a model source."""

from __future__ import annotations

import gzip
import io
import tarfile
from pathlib import Path
from typing import Protocol

from racer.model_io.sources import FolderSource, ModelSource, StoreSource, TarSource
from racer.shared.store import ObjectStore, join_key


class Destination(Protocol):
    def describe(self) -> str: ...

    def put_bytes(self, key: str, data: bytes) -> None: ...


class FolderDestination:
    """Plain files under a folder (no staging folder inside it, unlike LocalStore)."""

    def __init__(self, root: Path):
        self.root = Path(root)

    def describe(self) -> str:
        return str(self.root)

    def put_bytes(self, key: str, data: bytes) -> None:
        target = self.root / key
        target.parent.mkdir(parents=True, exist_ok=True)
        partial = target.with_name(target.name + ".partial")
        partial.write_bytes(data)
        partial.replace(target)


class ArchiveDestination:
    """A .tar.gz holding the layout at its root (DeepRacer-on-AWS's portable "virtual model" bundle).

    The archive is created on the first file and finished by `close()`; `discard()` removes a partial one.
    Byte-reproducible like the car bundle."""

    def __init__(self, path: Path):
        self.path = Path(path)
        self._file: io.BufferedWriter | None = None
        self._gzip: gzip.GzipFile | None = None
        self._tar: tarfile.TarFile | None = None

    def describe(self) -> str:
        return str(self.path)

    def put_bytes(self, key: str, data: bytes) -> None:
        if self._tar is None:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self._file = open(self.path, "wb")
            self._gzip = gzip.GzipFile(fileobj=self._file, mode="wb", mtime=0)
            self._tar = tarfile.open(fileobj=self._gzip, mode="w", format=tarfile.PAX_FORMAT)
        info = tarfile.TarInfo(key)
        info.size = len(data)
        info.mode = 0o644
        info.mtime = 0
        self._tar.addfile(info, io.BytesIO(data))

    def close(self) -> None:
        for part in (self._tar, self._gzip, self._file):
            if part is not None:
                part.close()
        self._tar = self._gzip = self._file = None

    def discard(self) -> None:
        self.close()
        self.path.unlink(missing_ok=True)


class StoreDestination:
    def __init__(self, store: ObjectStore, prefix: str):
        self.store = store
        self.prefix = prefix.strip("/")

    def describe(self) -> str:
        return StoreSource(self.store, self.prefix).describe()

    def put_bytes(self, key: str, data: bytes) -> None:
        self.store.put_bytes(join_key(self.prefix, key), data)


def read_back(destination: Destination) -> ModelSource:
    """The destination as a model source, to validate what was written."""
    if isinstance(destination, FolderDestination):
        return FolderSource(destination.root)
    if isinstance(destination, StoreDestination):
        return StoreSource(destination.store, destination.prefix)
    if isinstance(destination, ArchiveDestination):
        return TarSource(destination.path)
    raise TypeError(f"don't know how to read back {destination!r}")
