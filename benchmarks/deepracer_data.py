"""Where a bench finds DeepRacer's own files (routes/, models/, reward_functions/, simtrace/, frames/): `--data DIR`,
else RACER_DEEPRACER_DATA. racer ships none of them, so a bench that compares against them asks for the folder."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import click

from racer.shared.config import DEEPRACER_DATA_VARIABLE, deepracer_data

REINVENT_2018_ROUTE = Path("routes") / "reinvent_base.npy"
"""The re:Invent 2018 route, inside the data folder."""
GAZEBO_SAMPLE = Path("models") / "gazebo-sample-reinvent2018"
"""Two real Gazebo checkpoints (frozen graphs) and their model_metadata.json, inside the data folder."""


def data_option(command: Callable) -> Callable:
    """`--data DIR`: the folder of DeepRacer's files (default: RACER_DEEPRACER_DATA)."""
    return click.option(
        "--data",
        "data_dir",
        type=click.Path(file_okay=False, path_type=Path),
        default=None,
        help=f"A folder of DeepRacer's own files (routes/, models/, reward_functions/, ...). "
        f"Default: {DEEPRACER_DATA_VARIABLE}.",
    )(command)


def data_folder(given: Path | None) -> Path:
    """`--data`, else RACER_DEEPRACER_DATA; a usage error naming both when neither is a folder."""
    folder = given if given is not None else deepracer_data()
    if folder is None:
        raise click.UsageError(
            f"this bench compares against DeepRacer's own files: pass --data DIR or set {DEEPRACER_DATA_VARIABLE}"
        )
    if not folder.is_dir():
        raise click.UsageError(f"{folder}: no such folder (--data or {DEEPRACER_DATA_VARIABLE})")
    return folder
