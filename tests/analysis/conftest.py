"""Run layouts built in tmp_path from the real simtraces (read from ../shared/deepracer-data, never copied into the repo),
and an independent reading of the same CSVs with the csv module to check the analysis against."""

from __future__ import annotations

import csv
import shutil
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path

import pytest


def place(source: Path, target: Path) -> Path:
    target.parent.mkdir(parents=True, exist_ok=True)
    shutil.copyfile(source, target)
    return target


@pytest.fixture
def console_export(tmp_path, deepracer_data) -> Path:
    """The AWS console's "download logs" layout: sim-trace/training/training-simtrace and sim-trace/evaluation/<ts>."""
    root = tmp_path / "console-model"
    simtrace = deepracer_data / "simtrace"
    for iteration in (0, 1, 27):
        place(
            simtrace / f"console2022_training_{iteration}-iteration.csv",
            root / "sim-trace/training/training-simtrace" / f"{iteration}-iteration.csv",
        )
    place(
        simtrace / "console2022_evaluation_0-iteration.csv",
        root / "sim-trace/evaluation/20220612082523-IBZwYd0MRMqgwKlAe7bb0A/evaluation-simtrace/0-iteration.csv",
    )
    return root


@pytest.fixture
def drfc_single(tmp_path, deepracer_data) -> Path:
    """DeepRacer-for-Cloud, one worker: <prefix>/training-simtrace and <prefix>/evaluation-<ts>/evaluation-simtrace."""
    root = tmp_path / "rl-deepracer-sagemaker"
    simtrace = deepracer_data / "simtrace"
    for iteration in (0, 26):
        place(
            simtrace / f"drfc1_training_{iteration}-iteration.csv",
            root / "training-simtrace" / f"{iteration}-iteration.csv",
        )
    place(
        simtrace / "drfc1_evaluation_0-iteration.csv",
        root / "evaluation-20220709200242/evaluation-simtrace/0-iteration.csv",
    )
    return root


@pytest.fixture
def drfc_multi(tmp_path, deepracer_data) -> Path:
    """DeepRacer-for-Cloud, several workers: <prefix>/<worker>/training-simtrace (two real workers' files)."""
    root = tmp_path / "multi"
    simtrace = deepracer_data / "simtrace"
    place(simtrace / "drfc1_training_0-iteration.csv", root / "0/training-simtrace/0-iteration.csv")
    place(simtrace / "drfc1_training_26-iteration.csv", root / "0/training-simtrace/1-iteration.csv")
    place(simtrace / "drfc3_worker1_training_0-iteration.csv", root / "1/training-simtrace/0-iteration.csv")
    return root


@pytest.fixture
def reinvent_route(deepracer_data) -> Path:
    return deepracer_data / "routes" / "reinvent_base.npy"


@dataclass
class CsvEpisode:
    """An episode as read straight from the CSV rows, with the definitions written out again here."""

    rows: list[dict]

    @property
    def progress(self) -> float:
        return max(float(r["progress"]) for r in self.rows)

    @property
    def complete(self) -> bool:
        return self.progress >= 100.0

    @property
    def time_s(self) -> float:
        return sum(row["dt"] for row in self.rows)

    @property
    def reward(self) -> float:
        return sum(float(r["reward"]) for r in self.rows)


def csv_episodes(path: Path) -> dict[int, CsvEpisode]:
    """Episodes of one file; each row also gets `dt` = tstamp - previous row's tstamp (0 for prepare rows)."""
    episodes: dict[int, list[dict]] = defaultdict(list)
    previous = None
    with open(path, newline="") as handle:
        for row in csv.DictReader(handle):
            tstamp = float(row["tstamp"])
            row["dt"] = 0.0 if previous is None or row.get("episode_status") == "prepare" else tstamp - previous
            previous = tstamp
            episodes[int(row["episode"])].append(row)
    return {number: CsvEpisode(rows) for number, rows in episodes.items()}


@pytest.fixture
def read_csv_episodes():
    """csv_episodes, as a fixture (test modules cannot import this conftest under --import-mode=importlib)."""
    return csv_episodes
