"""A model packed as a ZIP: DeepRacer on AWS's "virtual model" download up to version 1.0.9 (named `.tar.gz` all the
same; 1.0.10 and later write a real tar.gz). `open_source` tells the two apart by their first bytes, not the name."""

from __future__ import annotations

import zipfile
from pathlib import Path, PurePosixPath

from racer.model_io.source_errors import SourceFormatError, SourceMissingError

ZIP_MAGIC = b"PK\x03\x04"
GZIP_MAGIC = b"\x1f\x8b"


def is_zip(path: Path) -> bool:
    with open(path, "rb") as handle:
        return handle.read(4) == ZIP_MAGIC


class ZipSource:
    """The layout at the archive root or inside one top-level folder, like TarSource."""

    def __init__(self, path: Path):
        self.path = Path(path)
        if not self.path.is_file():
            raise SourceMissingError(f"{self.path}: no such file")
        self.archive_bytes = self.path.stat().st_size
        try:
            self._zip = zipfile.ZipFile(self.path)
            infos = self._zip.infolist()
        except (zipfile.BadZipFile, OSError) as error:
            raise SourceFormatError(f"{self.path}: not a readable ZIP archive ({error})") from None
        members: dict[str, zipfile.ZipInfo] = {}
        for info in infos:
            name = PurePosixPath(info.filename)
            if name.is_absolute() or ".." in name.parts:
                raise SourceFormatError(f"{self.path}: member {info.filename!r} has an unsafe path")
            if not info.is_dir():
                members[name.as_posix()] = info
        tops = {key.split("/", 1)[0] for key in members}
        if len(tops) == 1 and all("/" in key for key in members):
            top = tops.pop() + "/"
            members = {key.removeprefix(top): info for key, info in members.items()}
        self._members = members

    def describe(self) -> str:
        return str(self.path)

    def list_files(self) -> dict[str, int]:
        return {key: info.file_size for key, info in sorted(self._members.items())}

    def read(self, key: str) -> bytes:
        return self._zip.read(self._members[key])
