"""DeepRacer's own models (trained in its Gazebo simulator) as the transfer bench drives them: the model folders under
a root, each imported through `racer model import`'s frozen-graph path into racer checkpoints."""

from __future__ import annotations

import json
import sys
from dataclasses import dataclass
from pathlib import Path

import click
import torch

from racer.shared.deepracer.model_metadata import ModelMetadata, parse_model_metadata
from racer.shared.policy.checkpoints import CheckpointStore
from racer.shared.store import LocalStore


@dataclass(frozen=True)
class RealModel:
    """One checkpoint of a DeepRacer model, as racer imported it."""

    folder: str
    checkpoint: str
    metadata: ModelMetadata
    network: torch.nn.Module

    @property
    def label(self) -> str:
        return f"{self.folder}/{self.checkpoint}"


def _metadata_file(folder: Path) -> Path | None:
    for candidate in (folder / "model_metadata.json", folder / "model" / "model_metadata.json"):
        if candidate.is_file():
            return candidate
    return None


def model_folders(root: Path) -> list[Path]:
    """Folders under `root` (itself included) that hold a model_metadata.json and frozen graphs; not their
    subfolders (a folder's own `model/` holds its graphs)."""
    found: list[Path] = []
    for folder in [root, *sorted(path for path in root.rglob("*") if path.is_dir())]:
        if any(folder.is_relative_to(parent) for parent in found):
            continue
        has_graphs = any(folder.glob("*.pb")) or any(folder.glob("model/*.pb"))
        if _metadata_file(folder) is not None and has_graphs:
            found.append(folder)
    return found


def import_real_models(folders: list[Path], store_root: Path) -> list[RealModel]:
    """Each folder through `racer model import`'s frozen-graph path; every checkpoint's policy, ready to act."""
    from racer.model_io.deepracer_import import frozen_graph_keys, import_frozen_graphs
    from racer.model_io.sources import FolderSource

    store = LocalStore(store_root)
    models = []
    for folder in folders:
        source = FolderSource(folder)
        keys = frozen_graph_keys(source.list_files())
        if not keys:
            raise click.ClickException(
                f"{folder}: no frozen graph (model.pb or model_<N>.pb) beside model_metadata.json"
            )
        name = folder.name.replace("_", "-")[:64]
        print(f"transfer bench: importing {folder} ({', '.join(keys)})", file=sys.stderr, flush=True)
        outcome = import_frozen_graphs(source, keys, store, name)
        checkpoints = CheckpointStore(store, name)
        metadata_path = _metadata_file(folder)
        metadata = parse_model_metadata(json.loads(metadata_path.read_text()), source=str(metadata_path))
        for checkpoint in outcome.written:
            models.append(RealModel(folder.name, checkpoint, metadata, checkpoints.load_policy(checkpoint)))
    return models
