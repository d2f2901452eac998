"""`python -m benchmarks race`: a race's entrants per minute with `--workers` against `racer evaluate` one after another.

A time trial on re:Invent 2018 under DeepRacer's default race settings (the race file of docs/evaluation.md:
AVG_LAP_TIME, 3 laps, 2 s off-track and 5 s collision penalties, 20 minutes), videos on. The field: the two real Gazebo checkpoints
of DeepRacer's sample model in `--data` (each frozen graph in a folder of its own, as `racer model import` takes it),
the racer models given with `--entrant`, one broken folder the bench makes, re-entered under distinct names until there are
`--entrants` (every model given races, so the field may be larger). Every model is imported once with `racer model
import` (a racer model folder: its `model/` copied) before the clock starts, and each entrant gets a
store prefix of its own, so both timed runs do the same work: evaluations from the store (and the broken folder's
import, which fails). The race is `racer race ... --workers N` as a user runs it; the baseline is `racer evaluate` for
each entrant, one after another, with the same seed and the race's rules. The board must be full: a row per entrant,
the broken one with its reason. `--multi-car` adds a head-to-model race and an F1 race, each run twice with one seed
(`race_multi_car.py`). Prints one JSON line; progress on stderr.
"""

from __future__ import annotations

import json
import os
import time
from pathlib import Path
from typing import Any

import click
import yaml

from benchmarks.deepracer_data import GAZEBO_SAMPLE, REINVENT_2018_ROUTE, data_folder, data_option
from benchmarks.race_field import (
    BROKEN_NAME,
    SAMPLE_GENERATION,
    broken_folder,
    copy_entrants,
    field_of,
    gazebo_folders,
    import_models,
    racer_command,
    run_logged,
    say,
)
from benchmarks.workdir import bench_workdir, cpu_description
from racer.options.race import race_workers_option
from racer.options.training import seed_option
from racer.shared.model_layout import evaluation_metrics_timestamp

GOAL_RATIO = 1.7
"""Entrants per minute of the race over the one-after-another baseline, on 2 cores (issue 32)."""
DEFAULT_RULES: dict[str, Any] = {
    "raceType": "TIME_TRIAL",
    "timingMethod": "AVG_LAP_TIME",
    "resettingBehaviorConfig": {"continuousLap": False, "offTrackPenaltySeconds": 2, "collisionPenaltySeconds": 5},
    "submissionTerminationConditions": {"minimumLaps": 3, "maximumLaps": 3, "maxTimeInMinutes": 20},
}
"""DeepRacer's default race settings (docs/evaluation.md, "Races"); maxResets absent: the console's 10000."""
QUICK_LIMITS = {"minimumLaps": 1, "maximumLaps": 1, "maxTimeInMinutes": 1}
"""`--quick`: one lap in at most a simulated minute (a Gazebo checkpoint laps re:Invent 2018 in about 10 s), and
maxResets 0: the first exit ends an entrant's lap, so an untrained `--entrant` costs seconds, in the race and in
`racer evaluate` alike (which has no time limit)."""


def evaluate_args(race: dict[str, Any], name: str, seed: int, out: Path) -> list[str]:
    """`racer evaluate` with the race's settings (racer.race.entrant_evaluation.evaluation_config): deepracer mode,
    base world."""
    limits = race["submissionTerminationConditions"]
    resetting = race["resettingBehaviorConfig"]
    args = ["evaluate", "--model-prefix", name, "--mode", "deepracer", "--track", race["trackConfig"]["trackId"]]
    args += ["--world", "base", "--trials", str(limits["maximumLaps"])]
    args += ["--continuous" if resetting["continuousLap"] else "--no-continuous"]
    args += ["--resets", str(race.get("maxResets", 10000))]
    args += ["--off-track-penalty", str(resetting["offTrackPenaltySeconds"])]
    args += ["--collision-penalty", str(resetting["collisionPenaltySeconds"])]
    args += ["--generation", SAMPLE_GENERATION]
    return [*args, "--video", "--no-mcap", "--seed", str(seed), "--out", str(out / name)]


def sequential_laps(out: Path, name: str) -> list[int]:
    """Lap times (ms) of a baseline evaluation, from its local copy's metrics file."""
    folder = out / name
    metrics = sorted(
        (timestamp, path)
        for path in folder.glob("metrics/**/*.json")
        if (timestamp := evaluation_metrics_timestamp(path.relative_to(folder).as_posix())) is not None
    )
    if not metrics:
        return []
    return [int(lap["elapsed_time_in_milliseconds"]) for lap in json.loads(metrics[-1][1].read_text())["metrics"]]


def board_check(board: dict[str, Any], names: list[str]) -> dict[str, Any]:
    """Full: one row per entrant; the broken entrant's row has its reason; every other row its videos."""
    rows = {row["entrant"]: row for row in board["leaderboard"]}
    broken = rows.get(BROKEN_NAME, {})
    raced = [name for name in names if name != BROKEN_NAME]
    with_videos = [name for name in raced if len(rows.get(name, {}).get("videos", {})) == 3]
    return {
        "rows": len(rows),
        "full": set(rows) == set(names) and bool(broken.get("dnfReason")),
        "broken_row": {"dnfReason": broken.get("dnfReason"), "errorCode": broken.get("errorCode")},
        "entrants_with_three_videos": len(with_videos),
        "ranked": sum(1 for row in rows.values() if row.get("rank")),
    }


def per_minute(count: int, wall_s: float) -> float:
    return round(count * 60.0 / wall_s, 2) if wall_s > 0 else 0.0


@click.command(name="race")
@click.option(
    "--entrants",
    "entrant_count",
    type=click.IntRange(min=2),
    default=12,
    show_default=True,
    help="Field size, the broken folder included; at least every model given and the broken folder.",
)
@click.option(
    "--entrant",
    "extra",
    multiple=True,
    type=click.Path(exists=True, path_type=Path),
    help="A racer model folder or anything `racer model import` takes; repeatable.",
)
@race_workers_option
@seed_option
@click.option(
    "--quick",
    is_flag=True,
    help="One lap each, the first exit ends it (a test's size: with --entrants 3, about a minute of work).",
)
@click.option("--multi-car", is_flag=True, help="Also a head-to-model and an F1 race, each twice with one seed.")
@data_option
def race_bench_command(
    entrant_count: int,
    extra: tuple[Path, ...],
    workers: int | None,
    seed: int,
    quick: bool,
    multi_car: bool,
    data_dir: Path | None,
) -> None:
    """A time trial of --entrants entrants (videos on) with --workers, against `racer evaluate` one after another."""
    from racer.race.runner import race_workers_for_the_cores

    data = data_folder(data_dir)
    route = data / REINVENT_2018_ROUTE
    workers = workers or race_workers_for_the_cores()
    env = {"MUJOCO_GL": "egl", **os.environ}
    with bench_workdir("racer-bench-race-") as work:
        store, logs = work / "store", work / "logs"
        logs.mkdir(parents=True)
        env["RACER_STORE"] = str(store)
        sources = [*gazebo_folders(work, data / GAZEBO_SAMPLE), *(path.resolve() for path in extra)]
        models = import_models(sources, store, logs, workers, env)
        names = field_of(models, max(entrant_count, len(models) + 1))  # every model given races
        copy_entrants(store, models, names)
        broken = broken_folder(work)
        race: dict[str, Any] = {"name": "bench-race", "trackConfig": {"trackId": str(route)}, **DEFAULT_RULES}
        if quick:
            race["submissionTerminationConditions"] = dict(QUICK_LIMITS)
            race["maxResets"] = 0
        race_file = work / "bench-race.yaml"
        race_file.write_text(yaml.safe_dump(race))
        field = [*names, f"{BROKEN_NAME}={broken}"]
        names.append(BROKEN_NAME)

        say(f"racing {len(field)} entrants, {workers} at a time")
        started = time.perf_counter()
        command = racer_command("race", str(race_file), *field, "--workers", str(workers), "--seed", str(seed))
        command += ["--generation", SAMPLE_GENERATION]
        status = run_logged([*command, "--out", str(work / "race"), "--video"], logs / "race.log", env)
        race_s = time.perf_counter() - started
        if status != 0:
            raise click.ClickException(f"racer race failed (exit status {status}); see {logs / 'race.log'}")
        board = json.loads((work / "race" / "leaderboard.json").read_text())

        say(f"race took {race_s:.1f} s; now racer evaluate for each entrant, one after another")
        sequential = work / "sequential"
        started = time.perf_counter()
        for name in names:
            if name == BROKEN_NAME:  # as the race does: its import fails
                args = ["model", "import", str(broken), BROKEN_NAME, "--store", str(work / "broken-store")]
            else:
                args = evaluate_args(race, name, seed, sequential)
            run_logged(racer_command(*args), logs / "sequential.log", env)
        sequential_s = time.perf_counter() - started

        rows = {row["entrant"]: row for row in board["leaderboard"]}
        same_laps = all(
            [int(lap["elapsed_time_in_milliseconds"]) for lap in rows[name]["laps"]]
            == sequential_laps(sequential, name)
            for name in names
            if name != BROKEN_NAME and name in rows
        )
        report: dict[str, Any] = {
            "benchmark": "race",
            "track": route.stem,
            "rules": race["timingMethod"],
            "laps": race["submissionTerminationConditions"]["maximumLaps"],
            "entrants": len(names),
            "workers": workers,
            "seed": seed,
            "race_s": round(race_s, 1),
            "sequential_s": round(sequential_s, 1),
            "race_entrants_per_min": per_minute(len(names), race_s),
            "sequential_entrants_per_min": per_minute(len(names), sequential_s),
            "ratio": round(sequential_s / race_s, 2) if race_s > 0 else None,
            "goal_ratio": GOAL_RATIO,
            "board": board_check(board, names),
            "same_laps_as_racer_evaluate": same_laps,
            "cpu": cpu_description(),
            "load_average_1min": round(os.getloadavg()[0], 2),  # other work on the machine slows both sides
        }
        if multi_car:
            from benchmarks.race_multi_car import multi_car_races

            report["multi_car"] = multi_car_races(work, models, route, seed=seed, quick=quick, env=env)
    print(json.dumps(report), flush=True)
