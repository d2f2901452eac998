"""The inputs of `racer model explain`: the model (a store prefix, a racer model folder, or anything `racer model
import` takes, imported into a temporary local store) and the frames (image files as the camera gives them, or racer's
own camera around the lap)."""

from __future__ import annotations

import contextlib
import json
import re
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import click
import numpy as np

FRAME_HEIGHT, FRAME_WIDTH = 120, 160
IMAGE_SUFFIXES = (".png", ".jpg", ".jpeg")


@dataclass(frozen=True)
class LoadedModel:
    label: str
    checkpoint: str
    metadata: object  # ModelMetadata
    network: object  # ActorCritic | SACNetworks


# -- the model ------------------------------------------------------------------------------------------------------


def _metadata(store, prefix: str, checkpoints, name: str):
    from racer.shared.deepracer.model_metadata import parse_model_metadata
    from racer.shared.model_layout import ModelLayout
    from racer.shared.store import ObjectNotFoundError

    try:
        return parse_model_metadata(json.loads(store.get_bytes(ModelLayout(prefix).model_metadata)), source=prefix)
    except ObjectNotFoundError:
        info = checkpoints.read_info(name)
        if info.model_metadata is None:
            raise click.ClickException(f"{prefix}: no model_metadata.json and none in checkpoint {name}") from None
        return parse_model_metadata(info.model_metadata, source=f"{prefix} ({name})")


def _from_store(store, prefix: str, checkpoint: str, label: str) -> LoadedModel:
    from racer.shared.policy.checkpoints import CheckpointError, CheckpointStore

    checkpoints = CheckpointStore(store, prefix)
    try:
        name = checkpoints.select(checkpoint)
        network = checkpoints.load_policy(name)
    except (CheckpointError, ValueError) as error:
        raise click.ClickException(f"{label}: {error}") from None
    return LoadedModel(label, name, _metadata(store, prefix, checkpoints, name), network)


def _wanted_graphs(keys: tuple[str, ...], checkpoint: str) -> tuple[str, ...]:
    """Only the graph that becomes the wanted checkpoint (each takes a TensorFlow process to read)."""
    from racer.model_io.deepracer_import import graph_checkpoint_number

    numbers = {key: graph_checkpoint_number(key) for key in keys}
    match = re.match(r"(\d+)_Step", checkpoint)
    wanted = int(match.group(1)) if match else max(numbers.values())
    chosen = tuple(key for key in keys if numbers[key] == wanted)
    if not chosen:
        raise click.ClickException(f"no frozen graph for checkpoint {checkpoint}; have {', '.join(keys)}")
    return chosen


def _import_source(location: str, store, checkpoint: str) -> str:
    """`racer model import`'s path into `store` as `explain`; returns the checkpoint name to load."""
    from racer.model_io.deepracer_import import (
        convert_tf_checkpoints,
        find_model_root,
        frozen_graph_keys,
        import_frozen_graphs,
        tensorflow_only_checkpoints,
    )
    from racer.model_io.import_export import import_model
    from racer.model_io.validate import validate_location, validate_model

    report, opened = validate_location(location)
    if opened is not None and not report.ok:
        graph_keys = frozen_graph_keys(opened.list_files())
        if graph_keys:
            keys = _wanted_graphs(graph_keys, checkpoint)
            click.echo(f"explain: reading the frozen graph {', '.join(keys)} (a TensorFlow process) ...", err=True)
            outcome = import_frozen_graphs(opened, keys, store, "explain")
            return outcome.written[-1]
        nested = find_model_root(opened)
        if nested is not None and validate_model(nested).ok:
            report, opened = validate_model(nested), nested
    if opened is None or not report.ok:
        problems = "; ".join(problem.render() for problem in report.problems)
        raise click.ClickException(f"{location} is not a model racer can import: {problems}")
    result = import_model(opened, store, "explain")
    if not result.report.ok or result.problems:
        raise click.ClickException(f"{location}: the import failed")
    if tensorflow_only_checkpoints(result.written):
        click.echo("explain: converting the TensorFlow checkpoints (a TensorFlow process) ...", err=True)
        convert_tf_checkpoints(store, "explain")
    return checkpoint


@contextlib.contextmanager
def open_model(model: str, store_location: str | None, checkpoint: str) -> Iterator[LoadedModel]:
    """A store prefix, a racer model folder, or a source imported into a temporary local store."""
    from racer.shared.policy.checkpoints import CheckpointStore
    from racer.shared.store import LocalStore

    path = Path(model).expanduser()
    if not model.startswith("s3://") and not path.exists():
        from racer.model_io.store_location import open_store_option

        yield _from_store(open_store_option(store_location), model.strip("/"), checkpoint, model)
        return
    if path.is_dir() and (path / "model" / "model_metadata.json").is_file():
        local = LocalStore(path.resolve().parent)
        if CheckpointStore(local, path.resolve().name).names():  # a model in racer's local store layout
            yield _from_store(local, path.resolve().name, checkpoint, model)
            return
    with tempfile.TemporaryDirectory(prefix="racer-explain-") as folder:
        store = LocalStore(Path(folder))
        name = _import_source(model, store, checkpoint)
        yield _from_store(store, "explain", name, model)


# -- frames ---------------------------------------------------------------------------------------------------------


def load_frames(paths: tuple[Path, ...]) -> tuple[list[str], np.ndarray]:
    """Image files and folders of them -> names and (N, 120, 160) uint8 grey frames as the camera gives them."""
    from PIL import Image

    from racer.shared.sim.sensors.camera import rgb_to_y

    files: list[Path] = []
    for path in paths:
        if path.is_dir():
            files += sorted(p for p in path.iterdir() if p.suffix.lower() in IMAGE_SUFFIXES)
        else:
            files.append(path)
    if not files:
        raise click.ClickException(f"no frames (PNG or JPEG) in {', '.join(map(str, paths))}")
    frames = []
    for path in files:
        try:
            image = Image.open(path)
            image.load()
        except OSError as error:
            raise click.ClickException(f"{path}: not an image: {error}") from None
        if image.size != (FRAME_WIDTH, FRAME_HEIGHT):
            image = image.resize((FRAME_WIDTH, FRAME_HEIGHT), Image.Resampling.BILINEAR)
        if image.mode == "L":  # already grey: taken as it is
            frames.append(np.asarray(image))
        else:
            frames.append(rgb_to_y(np.ascontiguousarray(np.asarray(image.convert("RGB")))))
    return [path.stem for path in files], np.stack(frames)


def racer_frames_of(count: int, world: str, track: str | Path) -> tuple[list[str], np.ndarray]:
    """racer's front camera at `count` evenly spread centre-line poses around the lap of `track` (a name on the
    route search path or a route file); a track that cannot be loaded is a usage error naming it."""
    from racer.model_io.pose_frames import render_lap
    from racer.shared.sim.sensors.camera import rgb_to_y
    from racer.shared.sim.tracks.track import TrackError

    try:
        rendered, _ = render_lap(track, world, count, full_resolution=False)
    except TrackError as error:
        raise click.BadParameter(str(error), param_hint="--track") from None
    return [f"racer-{world}-{k:03d}" for k in range(count)], np.stack([rgb_to_y(frame) for frame in rendered])
