"""DeepRacer's models become racer models: TensorFlow checkpoints, frozen graphs and DRoA's downloads.

* A model folder / archive / prefix with TensorFlow checkpoints (console, DRfC, DRoA's "virtual model" download,
  racer's own `--for droa` export) is copied by `import_model`, then `convert_tf_checkpoints` turns each copied
  TensorFlow checkpoint into a racer checkpoint of the same name (value network included when the checkpoint has
  it), so `racer evaluate` drives it and `--pretrained-prefix` continues training it.
* Frozen graphs with their model_metadata.json (the physical-car tarball `agent/model.pb`, a folder with `model.pb`,
  or DeepRacer's numbered graphs `model_<N>.pb`, at the folder's root or under `model/`) become racer checkpoints:
  `model.pb` checkpoint `0_Step-0.ckpt`, each `model_<N>.pb` checkpoint `<N>_Step-0.ckpt` (the highest is the last
  and the best); the policy from the graph, the value network fresh (a frozen graph holds only the policy).
* Archives are recognised by their first bytes (a ZIP named `.tar.gz` from DRoA <= 1.0.9, a real tar.gz since
  1.0.10) and searched for the model when it sits deeper than the archive root (the training-logs download).
"""

from __future__ import annotations

import json
import re
import tempfile
from dataclasses import dataclass
from pathlib import Path

from racer.model_io import checkpoints as ck
from racer.model_io.import_config import NETWORK_KEYS, imported_policy_config
from racer.model_io.sources import ModelSource
from racer.shared import model_layout
from racer.shared.deepracer.model_metadata import ModelMetadata, parse_model_metadata
from racer.shared.store import ObjectStore, join_key

__all__ = [
    "ConversionOutcome",
    "SubfolderSource",
    "frozen_graph_keys",
    "convert_tf_checkpoints",
    "find_model_root",
    "graph_checkpoint_number",
    "import_frozen_graphs",
    "tensorflow_only_checkpoints",
]

_CAR_GRAPHS = ("agent/model.pb", "model.pb")
_NUMBERED_GRAPH = re.compile(r"^(?:model/)?model_(\d+)\.pb$")


@dataclass(frozen=True)
class ConversionOutcome:
    written: tuple[str, ...]
    """Checkpoint names written in racer's format."""
    notes: tuple[str, ...]


class SubfolderSource:
    """A view of one folder inside another source (a model found deeper inside an archive)."""

    def __init__(self, source: ModelSource, folder: str):
        self.source = source
        self.folder = folder.strip("/")

    def describe(self) -> str:
        return f"{self.source.describe()}:{self.folder}"

    def list_files(self) -> dict[str, int]:
        start = self.folder + "/"
        return {
            key.removeprefix(start): size for key, size in self.source.list_files().items() if key.startswith(start)
        }

    def read(self, key: str) -> bytes:
        return self.source.read(f"{self.folder}/{key}")


def find_model_root(source: ModelSource) -> ModelSource | None:
    """The shallowest folder holding `model/.coach_checkpoint` or `model/deepracer_checkpoints.json`, when it is
    not the source's root (DRoA's training-logs download nests the model). None if there is none."""
    pointers = [
        key
        for key in source.list_files()
        if key.endswith((model_layout.COACH_CHECKPOINT, model_layout.DEEPRACER_CHECKPOINTS))
    ]
    folders = sorted({key.rsplit("/model/", 1)[0] for key in pointers if "/model/" in key}, key=lambda f: f.count("/"))
    return SubfolderSource(source, folders[0]) if folders else None


def frozen_graph_keys(files: dict[str, int]) -> tuple[str, ...]:
    """The frozen graphs to import when the source is a car bundle or a graph-only folder (no checkpoint): the car's
    one graph, else every numbered `model_<N>.pb` in checkpoint order. Empty when the source is something else."""
    if "model_metadata.json" not in files and model_layout.MODEL_METADATA not in files:
        return ()
    if ck.all_checkpoint_names(files):
        return ()
    for key in _CAR_GRAPHS:
        if key in files:
            return (key,)
    numbered = sorted((int(match.group(1)), key) for key in files if (match := _NUMBERED_GRAPH.match(key)))
    return tuple(key for _, key in numbered)


def graph_checkpoint_number(graph_key: str) -> int:
    """`model_30.pb` -> 30 (DeepRacer numbers its graphs by checkpoint); the car's `model.pb` -> 0."""
    match = _NUMBERED_GRAPH.match(graph_key)
    return int(match.group(1)) if match else 0


def _metadata(store: ObjectStore, model_name: str) -> tuple[ModelMetadata, bytes]:
    key = join_key(model_name, model_layout.MODEL_METADATA)
    data = store.get_bytes(key)
    return parse_model_metadata(json.loads(data.decode("utf-8-sig")), source=key), data


def tensorflow_only_checkpoints(keys: list[str] | tuple[str, ...]) -> list[str]:
    """Names of the complete TensorFlow checkpoints among `keys` that have no racer checkpoint beside them."""
    files = dict.fromkeys(keys, 0)
    return [
        name.name
        for name in ck.all_checkpoint_names(files)
        if not ck.is_racer_checkpoint(name, files) and not ck.missing_parts(name, files)
    ]


def convert_tf_checkpoints(store: ObjectStore, model_name: str) -> ConversionOutcome:
    """Turn every TensorFlow checkpoint under `<model_name>/model/` into a racer checkpoint of the same name.

    Raises UnsupportedGraphError (naming what racer cannot represent) or TensorFlowMissingError."""
    from racer.model_io.tensorflow.convert import network_from_tf_checkpoint
    from racer.shared.policy.checkpoints import CheckpointStore

    prefix = join_key(model_name, model_layout.MODEL_DIR) + "/"
    files = {key.removeprefix(model_name + "/"): 0 for key in store.list_keys(prefix)}
    tf_names = [
        name
        for name in ck.all_checkpoint_names(files)
        if not ck.is_racer_checkpoint(name, files) and not ck.missing_parts(name, files)
    ]
    if not tf_names:
        return ConversionOutcome((), ())
    metadata, _ = _metadata(store, model_name)
    model_files = {key.removeprefix(model_name + "/") for key in store.list_keys(model_name + "/")}
    config = imported_policy_config(
        metadata, model_files, lambda key: store.get_bytes(join_key(model_name, key)), model_name
    )
    checkpoints = CheckpointStore(store, model_name, keep=len(tf_names) + 4)
    pointer = checkpoints.latest_name()
    written, notes = [], []
    for name in tf_names:
        with tempfile.TemporaryDirectory(prefix="racer-tf-import-") as folder:
            for key in ck.checkpoint_files(name, files):
                (Path(folder) / key.removeprefix(ck.MODEL_DIR)).write_bytes(store.get_bytes(join_key(model_name, key)))
            imported = network_from_tf_checkpoint(Path(folder) / name.name, config, metadata.continuous_action_space)
        checkpoints.save(
            name.number,
            name.env_steps,
            imported.network,
            model_metadata=metadata,
            extra={"imported_from": "tensorflow checkpoint", "value_restored": imported.value_restored},
        )
        written.append(name.name)
        notes += [f"{name}: {note}" for note in imported.notes]
    if pointer is not None:  # save() moved the pointer to each converted checkpoint in turn
        store.put_bytes(join_key(model_name, model_layout.COACH_CHECKPOINT), (pointer + "\n").encode())
    return ConversionOutcome(tuple(written), tuple(notes))


def import_frozen_graphs(
    source: ModelSource, graph_keys: tuple[str, ...], store: ObjectStore, model_name: str
) -> ConversionOutcome:
    """Frozen graphs + model_metadata.json -> racer model `<model_name>`, one checkpoint per graph (see the module)."""
    from racer.model_io.tensorflow.convert import network_from_frozen_graph
    from racer.shared.policy.checkpoints import CheckpointRecord, CheckpointStore

    files = source.list_files()
    metadata_key = "model_metadata.json" if "model_metadata.json" in files else model_layout.MODEL_METADATA
    metadata = parse_model_metadata(
        json.loads(source.read(metadata_key).decode("utf-8-sig")), source=f"{source.describe()}/{metadata_key}"
    )
    config = imported_policy_config(metadata, files, source.read, source.describe())
    checkpoints = CheckpointStore(store, model_name, keep=len(graph_keys) + 4)
    checkpoints.put_model_metadata(metadata)
    for optional in ("reward_function.py", "training_params.yaml"):
        if optional in files:
            store.put_bytes(join_key(model_name, optional), source.read(optional))
    network_key = next((key for key in NETWORK_KEYS if key in files), None)
    if config.network is not None and network_key is not None:  # beside model_metadata.json, as the trainer puts it
        store.put_bytes(join_key(model_name, model_layout.NETWORK), source.read(network_key))
    written, notes = [], []
    for graph_key in sorted(graph_keys, key=graph_checkpoint_number):
        with tempfile.TemporaryDirectory(prefix="racer-tf-import-") as folder:
            graph_path = Path(folder) / "model.pb"
            graph_path.write_bytes(source.read(graph_key))
            imported = network_from_frozen_graph(graph_path, config)
        written.append(
            checkpoints.save(
                graph_checkpoint_number(graph_key),
                0,
                imported.network,
                model_metadata=metadata,
                extra={"imported_from": f"frozen graph {graph_key}", "value_restored": False},
            )
        )
        notes += [note for note in imported.notes if note not in notes]
    last = CheckpointRecord(written[-1], None, None)
    checkpoints.write_best_and_last(last, last)
    return ConversionOutcome(tuple(written), tuple(notes))
