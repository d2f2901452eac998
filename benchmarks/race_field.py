"""What the race bench's two halves share (`race.py`, `race_multi_car.py`): the field of entrants (the shared Gazebo
checkpoints, a broken folder, `--entrant` models imported once, re-entries under names of their own) and how the bench
runs racer's own commands."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

import click

BROKEN_NAME = "broken"


def say(message: str) -> None:
    print(f"race bench: {message}", file=sys.stderr, flush=True)


def gazebo_folders(work: Path, sample: Path) -> list[Path]:
    """One folder per frozen graph of the Gazebo sample (`model_15.pb`, `model_30.pb`), beside its metadata: two
    entrants, since `racer model import` of the sample folder would give one model with both checkpoints."""
    folders = []
    for graph in sorted(sample.glob("model_*.pb")):
        folder = work / "sources" / f"gazebo-{graph.stem.removeprefix('model_')}"
        folder.mkdir(parents=True, exist_ok=True)
        for file in (graph, sample / "model_metadata.json"):
            (folder / file.name).unlink(missing_ok=True)
            (folder / file.name).symlink_to(file)
        folders.append(folder)
    return folders


def broken_folder(work: Path) -> Path:
    """A folder `racer model import` refuses (no model_metadata.json, no checkpoint): the race must still finish."""
    folder = work / "sources" / BROKEN_NAME
    folder.mkdir(parents=True, exist_ok=True)
    (folder / "notes.txt").write_text("not a model: the race bench's broken entrant\n")
    return folder


SAMPLE_GENERATION = "2019"
"""The races and their baseline run in the generation the field's two Gazebo checkpoints were trained in (python -m benchmarks
transfer judges them there too); a racer model entrant races there with them."""


def racer_command(*args: str) -> list[str]:
    return [sys.executable, "-m", "racer.cli", *args]


def run_logged(command: list[str], log_path: Path, env: dict[str, str]) -> int:
    """In the log's folder's parent (the bench's folder), so no entrant name is taken for a folder of the caller's."""
    with log_path.open("a") as log:
        done = subprocess.run(
            command, stdout=log, stderr=subprocess.STDOUT, env=env, cwd=log_path.parent.parent, check=False
        )
    return done.returncode


def is_racer_model_folder(path: Path) -> bool:
    """A racer model in a local store's layout (racer-data/MODEL): its `model/` is all an evaluation reads."""
    return (path / "model" / "model_metadata.json").is_file() and any((path / "model").glob("*.ckpt.json"))


def copy_raced_checkpoint(model_dir: Path, target: Path) -> None:
    """The files an evaluation of `model_dir`'s best checkpoint reads (metadata, pointers, that checkpoint's weights
    and ONNX), not its other checkpoints nor any optimiser state: a 20-checkpoint model is 0.6 GB, its raced
    checkpoint a few MB."""
    from racer.shared.model_layout import CheckpointName, inference_model
    from racer.shared.policy.checkpoints import CheckpointStore
    from racer.shared.store import LocalStore

    store = LocalStore(model_dir.parent.parent)
    best = CheckpointName.parse(CheckpointStore(store, model_dir.parent.name).select("best"))
    best_onnx = inference_model(best.number, "onnx").rsplit("/", 1)[-1]
    shutil.rmtree(target, ignore_errors=True)
    target.mkdir(parents=True)
    for file in model_dir.iterdir():
        owner = CheckpointName.of_file(file.name)
        if owner is not None:
            wanted = owner == best and ".optimizer." not in file.name
        elif file.name.startswith("model_") and file.suffix == ".onnx":
            wanted = file.name == best_onnx
        else:
            wanted = file.is_file()
        if wanted:
            shutil.copy2(file, target / file.name)


def import_models(sources: list[Path], store: Path, logs: Path, workers: int, env: dict[str, str]) -> list[str]:
    """Every source into the bench's store (untimed), `workers` at a time: a racer model folder's `model/` is copied,
    anything else goes through `racer model import`; returns the model names."""
    names = [source.name.replace("_", "-")[:48] for source in sources]
    if len(set(names)) != len(names) or BROKEN_NAME in names:
        raise click.ClickException(f"--entrant folders need names of their own, not {BROKEN_NAME}: {', '.join(names)}")
    pending = []
    for source, name in zip(sources, names, strict=True):
        if is_racer_model_folder(source):
            shutil.rmtree(store / name, ignore_errors=True)
            copy_raced_checkpoint(source / "model", store / name / "model")
        else:
            pending.append((source, name))
    running: list[tuple[subprocess.Popen, str]] = []
    failed = []
    while pending or running:
        while pending and len(running) < workers:
            source, name = pending.pop(0)
            say(f"importing {source} as {name}")
            log = (logs / f"import-{name}.log").open("w")
            command = racer_command("model", "import", str(source), name, "--store", str(store), "--overwrite")
            running.append((subprocess.Popen(command, stdout=log, stderr=subprocess.STDOUT, env=env), name))
            log.close()
        process, name = running.pop(0)
        if process.wait() != 0:
            failed.append(name)
    if failed:
        raise click.ClickException(f"racer model import failed for {', '.join(failed)} (logs in {logs})")
    return names


def field_of(models: list[str], count: int) -> list[str]:
    """`count - 1` entrant names cycling over the models (re-entries: `<model>-2`, `<model>-3`, ...)."""
    names = []
    for index in range(count - 1):
        model = models[index % len(models)]
        entry = index // len(models) + 1
        names.append(model if entry == 1 else f"{model}-{entry}")
    return names


def copy_entrants(store: Path, models: list[str], names: list[str]) -> None:
    """Each entrant's own store prefix (a copy of its model's `model/`): two evaluations of one prefix in the same
    second would write the same evaluation folder."""
    for index, name in enumerate(names):
        model = models[index % len(models)]
        if name != model:
            shutil.rmtree(store / name, ignore_errors=True)
            copy_raced_checkpoint(store / model / "model", store / name / "model")
