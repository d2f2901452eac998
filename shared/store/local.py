"""A directory that behaves like a bucket: key `a/b/c` is the file `<root>/a/b/c`."""

from __future__ import annotations

import os
import tempfile
from pathlib import Path

from racer.shared.store.base import ObjectNotFoundError, validate_key

_STAGING_DIR = ".racer-staging"
"""Files are written here first and renamed into place, so a reader never sees half a file."""


class LocalStore:
    def __init__(self, root: Path):
        self.root = Path(root)
        self.root.mkdir(parents=True, exist_ok=True)
        (self.root / _STAGING_DIR).mkdir(exist_ok=True)

    def describe(self) -> str:
        return str(self.root)

    def _path(self, key: str) -> Path:
        return self.root / validate_key(key)

    def put_bytes(self, key: str, data: bytes) -> None:
        target = self._path(key)
        target.parent.mkdir(parents=True, exist_ok=True)
        fd, staging = tempfile.mkstemp(dir=self.root / _STAGING_DIR)
        try:
            with os.fdopen(fd, "wb") as handle:
                handle.write(data)
            os.replace(staging, target)
        finally:
            if os.path.exists(staging):
                os.unlink(staging)

    def get_bytes(self, key: str) -> bytes:
        try:
            return self._path(key).read_bytes()
        except (FileNotFoundError, IsADirectoryError, NotADirectoryError):
            raise ObjectNotFoundError(self.describe(), key) from None

    def list_keys(self, prefix: str) -> list[str]:
        keys = []
        # Walk only below the prefix's folder part ("m/model/x" -> <root>/m/model): a store holds many runs.
        folder = prefix.rpartition("/")[0]
        start = self.root
        if folder and not any(part in {"", ".", ".."} for part in folder.split("/")):
            start = self.root / folder
        for dirpath, dirnames, filenames in os.walk(start):
            if Path(dirpath) == self.root and _STAGING_DIR in dirnames:
                dirnames.remove(_STAGING_DIR)
            rel_dir = Path(dirpath).relative_to(self.root).as_posix()
            for name in filenames:
                key = name if rel_dir == "." else f"{rel_dir}/{name}"
                if key.startswith(prefix):
                    keys.append(key)
        return sorted(keys)

    def delete(self, key: str) -> None:
        path = self._path(key)
        try:
            path.unlink()
        except FileNotFoundError:
            return
        # Drop directories left empty, as a bucket has no empty "folders".
        parent = path.parent
        while parent != self.root:
            try:
                parent.rmdir()
            except OSError:
                break
            parent = parent.parent

    def exists(self, key: str) -> bool:
        return self._path(key).is_file()

    def size(self, key: str) -> int:
        try:
            return self._path(key).stat().st_size
        except FileNotFoundError:
            raise ObjectNotFoundError(self.describe(), key) from None
