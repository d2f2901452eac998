"""`python -m benchmarks race --multi-car`: a head-to-model race of two racer models and an F1 race of four cars, each run
twice with one seed. Both must complete (every car a row with its crash count) and give the same board twice: the
multi-car loop is deterministic, so a board that changes between runs is a bug, not noise."""

from __future__ import annotations

import json
import time
from pathlib import Path
from typing import Any

import yaml

from benchmarks.race_field import (
    SAMPLE_GENERATION,
    copy_entrants,
    field_of,
    racer_command,
    run_logged,
    say,
)

MULTI_CAR_LAPS = 3
QUICK_LAPS = 1


def _race_file(work: Path, name: str, race_type: str, laps: int, route: Path) -> Path:
    race = {
        "name": name,
        "trackConfig": {"trackId": str(route)},
        "raceType": race_type,
        "timingMethod": "BEST_LAP_TIME",
        "submissionTerminationConditions": {"minimumLaps": 1, "maximumLaps": laps, "maxTimeInMinutes": 2 * laps},
    }
    path = work / f"{name}.yaml"
    path.write_text(yaml.safe_dump(race))
    return path


def _run_twice(work: Path, race_file: Path, names: list[str], seed: int, env: dict[str, str]) -> dict[str, Any]:
    boards, walls = [], []
    for run in ("one", "two"):
        out = work / f"{race_file.stem}-{run}"
        started = time.perf_counter()
        command = racer_command("race", str(race_file), *names, "--seed", str(seed), "--out", str(out), "--video")
        command += ["--generation", SAMPLE_GENERATION]
        status = run_logged(command, work / "logs" / f"{race_file.stem}.log", env)
        walls.append(round(time.perf_counter() - started, 1))
        board_path = out / "leaderboard.csv"
        boards.append(board_path.read_text() if status == 0 and board_path.is_file() else None)
    rows = []
    if boards[0] is not None:
        rows = json.loads((work / f"{race_file.stem}-one" / "leaderboard.json").read_text())["leaderboard"]
    complete = len(rows) == len(names) and all("multiCar" in row and row["collisionCount"] is not None for row in rows)
    return {
        "entrants": names,
        "wall_s": walls,
        "complete": complete,
        "identical_boards": boards[0] is not None and boards[0] == boards[1],
        "crashes": {row["entrant"]: row["collisionCount"] for row in rows},
        "finishing_order": [row["entrant"] for row in sorted(rows, key=_place)],
        "top_view_video": bool(rows) and (work / f"{race_file.stem}-one" / "videos" / "all-cars-topview.mp4").is_file(),
    }


def _place(row: dict[str, Any]) -> int:
    return int(row.get("multiCar", {}).get("finishingPlace") or 10_000)


def multi_car_races(
    work: Path, models: list[str], route: Path, *, seed: int, quick: bool, env: dict[str, str]
) -> dict[str, Any]:
    """HEAD_TO_MODEL of the first two models and F1 of four cars (the models re-entered when fewer) on `route`."""
    laps = QUICK_LAPS if quick else MULTI_CAR_LAPS
    store = Path(env["RACER_STORE"])
    pair = field_of(models, 3)
    four = field_of(models, 5)
    copy_entrants(store, models, four)
    say(f"head-to-model of {', '.join(pair)}, {laps} lap(s), twice")
    head_to_model = _run_twice(work, _race_file(work, "bench-h2m", "HEAD_TO_MODEL", laps, route), pair, seed, env)
    say(f"F1 of {', '.join(four)}, {laps} lap(s), twice")
    f1 = _run_twice(work, _race_file(work, "bench-f1", "F1", laps, route), four, seed, env)
    return {"laps": laps, "head_to_model": head_to_model, "f1": f1}
