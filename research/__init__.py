"""Studies that answered a question about racer once, kept so their answers can be reproduced.

Not part of the product: the wheel does not install this folder and nothing under racer/, shared/, trainer/,
rollout_worker/, evaluation_worker/ or tracks/ imports it (tests/foundation/test_no_research_imports.py). A study
runs from the repository root with the project's environment, `python -m research.<study> ...`, and may import
racer. README.md lists the studies.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import click

from racer.shared.config import deepracer_data

DEEPRACER_DATA = deepracer_data() or Path(__file__).resolve().parents[1].parent / "shared" / "deepracer-data"
"""The DeepRacer test data (real simtraces, routes, the Gazebo frames, real models), every study's default `--data`:
RACER_DEEPRACER_DATA as the benches read it, else the folder beside the checkout."""


def data_option(reads: str) -> Callable:
    """`--data`, the DeepRacer test data folder (default: the one beside the checkout); `reads` names what the
    study takes from it."""
    return click.option(
        "--data",
        type=click.Path(exists=True, file_okay=False, path_type=Path),
        default=DEEPRACER_DATA,
        show_default=True,
        help=f"The DeepRacer test data ({reads}).",
    )


def simtraces_option(command: Callable) -> Callable:
    """`--simtraces`: a real simtrace CSV or a folder of them (default: the test data's `simtrace/`)."""
    return click.option(
        "--simtraces",
        type=click.Path(exists=True, path_type=Path),
        default=DEEPRACER_DATA / "simtrace",
        show_default=True,
        help="A real simtrace CSV or a folder of them (DeepRacer runs on re:Invent 2018).",
    )(command)


def route_option(command: Callable) -> Callable:
    """`--route`: the route the simtraces were driven on (default: re:Invent 2018); files of other tracks are left
    out (`benchmarks.fidelity.simtrace_replay.replay_files`)."""
    return click.option(
        "--route",
        type=click.Path(exists=True, dir_okay=False, path_type=Path),
        default=DEEPRACER_DATA / "routes" / "reinvent_base.npy",
        show_default=True,
        help="The route the simtraces were driven on; files logged on another track are left out.",
    )(command)
