"""`python -m benchmarks transfer --matrix`: does a model trained in one generation drive in the others?

For each training generation (default `simapp6`, today's simulator; `--train-profile` replaces its car) and with and
without `RACER_DYNAMICS_RANDOMIZATION`, a model is trained for `--minutes` with the reverse-check setup (issue 29):
the re:Invent 2018 sample's `model_metadata.json` (12 actions), the AWS centre-line reward
(`reward_functions/awsdoc_example_1.py`), `custom_files/hyperparameters.json`, re:Invent 2018, world base
(`--train-world`: others), fp32, one seed, through the same local training `racer train` runs. The last checkpoint of each then drives greedily in every
generation (or each `--generation` / `--car-profile` given) from `--starts` evenly spaced starts, as the transfer
bench drives the real checkpoints. One JSON line: `matrix[trained in][driven in]` = laps / mean progress. The goal
(issues 29, 44): trained in `simapp6` with dynamics randomisation, >= 8 of 10 laps in every generation.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from benchmarks.workdir import bench_workdir, cpu_description, read_iteration_records
from racer.defaults import DEFAULT_CUSTOM_FILES
from racer.options.training import DEFAULT_WORKERS
from racer.shared.run_settings import RunOptions

SAMPLE_MODEL = "gazebo-sample-reinvent2018"
REWARD_FUNCTION = "awsdoc_example_1.py"
TRAIN_GENERATIONS = ("simapp6",)
TRAIN_WORLDS = ("base",)
"""The reverse-check setup's: every worker on the base world. `racer train` spreads its workers over all four."""
DEFAULT_MINUTES = 15.0


@dataclass(frozen=True)
class MatrixCell:
    """One training run of the matrix: a generation, a car profile in place of its car ("" = its own), randomised
    or not."""

    generation: str
    profile: str
    dynamics_randomization: bool

    @property
    def model_prefix(self) -> str:
        car = f"-{self.profile}" if self.profile else ""
        return f"matrix-{self.generation}{car}-{'dr' if self.dynamics_randomization else 'fixed'}"


@dataclass(frozen=True)
class DriveCar:
    """Where a matrix model is driven: a generation, and a car profile in place of its car ("" = its own)."""

    generation: str
    profile: str = ""

    @property
    def label(self) -> str:
        return f"{self.generation}/{self.profile}" if self.profile else self.generation

    def env_config(self, track: Path, metadata: object):
        from racer.shared.sim.car.dynamics import car_profile
        from racer.shared.sim.config import EnvConfig

        car = car_profile(self.profile) if self.profile else None
        return EnvConfig(
            track=track, world="base", model_metadata=metadata, generation=self.generation, car_dynamics=car
        )


def write_custom_files(folder: Path, shared_data: Path) -> Path:
    """The reverse-check setup's custom files: the sample's metadata, the centre-line reward, racer's hyperparameters."""
    folder.mkdir(parents=True, exist_ok=True)
    sources = {
        "model_metadata.json": shared_data / "models" / SAMPLE_MODEL / "model_metadata.json",
        "reward_function.py": shared_data / "reward_functions" / REWARD_FUNCTION,
        "hyperparameters.json": DEFAULT_CUSTOM_FILES / "hyperparameters.json",
    }
    for name, source in sources.items():
        (folder / name).write_bytes(source.read_bytes())
    return folder


def train_cell(
    cell: MatrixCell,
    workdir: Path,
    custom: Path,
    track: Path,
    minutes: float,
    workers: int,
    seed: int,
    worlds: tuple[str, ...] = TRAIN_WORLDS,
):
    """Train one cell's model to the time limit, worker i on `worlds[i % len(worlds)]` as `racer train` spreads
    them; returns (store root, iteration records)."""
    from racer.local.run import LocalRunPlan, run_local_training
    from racer.shared.config import LocalStoreSettings, RedisSettings, ServiceSettings

    store_root = workdir / "store"
    plan = LocalRunPlan(
        model_prefix=cell.model_prefix,
        custom_files=custom,
        run=RunOptions(
            num_workers=workers,
            track=str(track),
            worlds=worlds,
            car_profile=cell.profile,
            dynamics_randomization=cell.dynamics_randomization,
            generation=cell.generation,
        ),
        max_episodes=None,
        max_minutes=minutes,
        use_minio=False,
        log_dir=workdir / "logs" / cell.model_prefix,
        seed=seed,
        trainer_options=("--precision", "fp32"),
    )
    base = ServiceSettings(redis=RedisSettings(), store=LocalStoreSettings(root=store_root))
    with contextlib.redirect_stdout(sys.stderr):  # the training's progress lines; stdout stays the one JSON line
        run_local_training(plan, base)
    return store_root, read_iteration_records(store_root, plan)


@dataclass(frozen=True)
class TrainedModel:
    """A matrix model's last checkpoint, shaped as the transfer bench's `drive` takes a model."""

    label: str
    metadata: object
    network: object


def drive_last_checkpoint(
    store_root: Path, cell: MatrixCell, track: Path, cars: tuple[DriveCar, ...], starts: int, drive: Callable
):
    """The cell's last checkpoint, greedy in every car (`drive` is the transfer bench's): {car label: figures},
    and the checkpoint's name."""
    from racer.shared.deepracer.model_metadata import parse_model_metadata
    from racer.shared.policy.checkpoints import CheckpointStore
    from racer.shared.store import LocalStore

    checkpoints = CheckpointStore(LocalStore(store_root), cell.model_prefix)
    last = checkpoints.latest_name()
    if last is None:
        return None, {}
    metadata_path = store_root / cell.model_prefix / "model" / "model_metadata.json"
    metadata = parse_model_metadata(json.loads(metadata_path.read_text()), source=str(metadata_path))
    model = TrainedModel(f"{cell.model_prefix}/{last}", metadata, checkpoints.load_policy(last))
    drives = {}
    for car in cars:
        figures = drive(model, car.env_config(track, metadata), starts)
        print(
            f"transfer matrix: {cell.model_prefix}/{last} in {car.label}: {figures['laps']}/{starts} laps, "
            f"mean progress {figures['mean_progress']} %",
            file=sys.stderr,
            flush=True,
        )
        drives[car.label] = figures
    return last, drives


def run_matrix(
    shared_data: Path,
    track: Path,
    drive: Callable,
    train_generations: tuple[str, ...] = TRAIN_GENERATIONS,
    train_profiles: tuple[str, ...] = ("",),
    drive_cars: tuple[DriveCar, ...] | None = None,
    minutes: float = DEFAULT_MINUTES,
    starts: int = 10,
    workers: int = DEFAULT_WORKERS,
    seed: int = 0,
    randomizations: tuple[bool, ...] = (False, True),
    keep_models: Path | None = None,
    train_worlds: tuple[str, ...] = TRAIN_WORLDS,
) -> dict:
    """Train every (generation, profile, randomisation in `randomizations`) cell and drive each in every car of
    `drive_cars` (default: every generation with its own car) with `drive(model, config, starts)` (the transfer
    bench's); the matrix as a dict."""
    from racer.shared.sim.generations.catalog import GENERATION_NAMES

    drive_cars = drive_cars or tuple(DriveCar(name) for name in GENERATION_NAMES)
    cells = [
        MatrixCell(generation, profile, randomized)
        for generation in train_generations
        for profile in train_profiles
        for randomized in randomizations
    ]
    started = time.monotonic()
    result: dict = {
        "benchmark": "transfer-matrix",
        "cpu": cpu_description(),
        "cores": len(os.sched_getaffinity(0)),
        "minutes_per_model": minutes,
        "workers": workers,
        "seed": seed,
        "precision": "fp32",
        "track": str(track),
        "train_worlds": list(train_worlds),
        "runs": [],
        "matrix": {},
    }
    with bench_workdir("racer-transfer-matrix-") as workdir:
        custom = write_custom_files(workdir / "custom_files", shared_data)
        for cell in cells:
            load_before = os.getloadavg()[0]
            store_root, records = train_cell(cell, workdir, custom, track, minutes, workers, seed, train_worlds)
            checkpoint, drives = drive_last_checkpoint(store_root, cell, track, drive_cars, starts, drive)
            if keep_models is not None:  # for `--racer-model` reverse checks after the bench's folder is gone
                shutil.copytree(store_root / cell.model_prefix, keep_models / cell.model_prefix, dirs_exist_ok=True)
            result["runs"].append(
                {
                    "model": cell.model_prefix,
                    "generation": cell.generation,
                    "car_profile": cell.profile,
                    "dynamics_randomization": cell.dynamics_randomization,
                    "iterations": len(records),
                    "env_steps": records[-1]["env_steps_total"] if records else 0,
                    "checkpoint": checkpoint,
                    "load_average_1min": [round(load_before, 2), round(os.getloadavg()[0], 2)],
                    "drives": drives,
                }
            )
            result["matrix"][cell.model_prefix] = {
                car: f"{figures['laps']}/{figures['starts']} {figures['mean_progress']} %"
                for car, figures in drives.items()
            }
    result["wall_minutes"] = round((time.monotonic() - started) / 60, 1)
    return result
