"""Who races: `[NAME=]SOURCE` arguments become entrants, named and checked before the start.

SOURCE is a model prefix already in the store (RACER_STORE), or anything `racer model import` takes: a folder,
a .tar.gz / .zip (a DRoA download, a car tarball), a DeepRacer-for-Cloud folder, s3://bucket/prefix. An imported
entrant lands under the race's own prefix, `races/<race>/<entrant>`, never among the user's models. The name is
NAME, else the source's last path component (archive suffixes dropped); two entrants with one name are refused.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

from racer.shared.store import ObjectStore

ENTRANT_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9-]{0,63}$")
_ARCHIVE_SUFFIXES = (".tar.gz", ".tgz", ".tar", ".zip")
RACES_PREFIX = "races"


class EntrantError(ValueError):
    """Entrants that cannot start (a duplicate or unusable name, a source that is neither a model nor a file)."""


@dataclass(frozen=True)
class Entrant:
    name: str
    source: str
    """As given on the command line."""
    kind: str
    """`store`: a model prefix in the store; `import`: something `racer model import` reads."""
    model_prefix: str
    """Where the evaluation reads the model: the store prefix, or races/<race>/<name> for imports."""


def _default_name(source: str) -> str:
    text = source.rstrip("/")
    last = text.rsplit("/", 1)[-1] if "/" in text else text
    for suffix in _ARCHIVE_SUFFIXES:
        if last.lower().endswith(suffix):
            last = last[: -len(suffix)]
            break
    return re.sub(r"[^A-Za-z0-9-]+", "-", last).strip("-")[:64]


def _is_store_model(store: ObjectStore, prefix: str) -> bool:
    prefix = prefix.strip("/")
    return bool(prefix) and bool(store.list_keys(prefix + "/model/"))


def parse_entrants(arguments: tuple[str, ...] | list[str], store: ObjectStore, race_name: str) -> tuple[Entrant, ...]:
    """Name every entrant and decide how it gets into the store; raises EntrantError before anything runs."""
    if not arguments:
        raise EntrantError("no entrants: give at least one model (a store prefix, a folder, an archive, s3://...)")
    entrants: list[Entrant] = []
    seen: dict[str, str] = {}
    for argument in arguments:
        name, separator, source = argument.partition("=")
        if not separator or "/" in name or name.startswith(("s3:", ".")):
            name, source = "", argument
        source = source.strip()
        name = name.strip() or _default_name(source)
        if not ENTRANT_NAME.match(name):
            raise EntrantError(
                f"entrant {argument!r}: name {name!r} must be 1-64 letters, digits and hyphens; give NAME=SOURCE"
            )
        if name in seen:
            raise EntrantError(
                f"two entrants are named {name!r} ({seen[name]!r} and {argument!r}); give one of them NAME=SOURCE"
            )
        seen[name] = argument
        if source.startswith("s3://") or Path(source).expanduser().exists():
            kind, prefix = "import", f"{RACES_PREFIX}/{race_name}/{name}"
        elif _is_store_model(store, source):
            kind, prefix = "store", source.strip("/")
        else:
            kind, prefix = "missing", source.strip("/")
        entrants.append(Entrant(name=name, source=source, kind=kind, model_prefix=prefix))
    return tuple(entrants)
