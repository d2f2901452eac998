"""`python -m benchmarks race-pace`: train from scratch with the fast-lap recipe for a fixed wall time, judge every
checkpoint on 3 consecutive laps as DeepRacer's continuous evaluation drives them, and print one JSON line: the best
lap and the best 3-lap average without a reset (when each was first reached), the curve of bests against minutes, the
car's own lap-time bound on the same track and the policy's ratio to it, and where the wall time went.

The run is `racer train`'s processes (racer.local.run) with `racer recipe`'s folder for the judged track and car,
made in the run's folder (racer.recipe; or `--custom-files`, racer/defaults/racing/discrete for the fixed racing
recipe), and the bench's evaluation keys over its workers.json: MIN_EVAL_TRIALS 3, RACER_EVAL_CONTINUOUS (racer.rollout_worker.checkpoint_evaluation:
worker 0 drives the laps from the start line, the first reset ending the run) and a step cap. The car and the look are
the generation's (`--generation`); the bench never changes either. The bound (racer.racing_line) is worker
0's car in worker 0's world, the one the evaluations drive (with the default recipe, the line the recipe was made from:
the same computation, done once).
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import resource
import shutil
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import click

from benchmarks.race_pace_laps import CheckpointLaps, lap_to_draw, pace_figures
from benchmarks.race_pace_losses import lap_against_line, loss_summary
from benchmarks.race_pace_picture import draw_pace, drive_lap_again, keep_checkpoint
from benchmarks.time_shares import time_shares
from benchmarks.time_to_lap import hyperparameter_overrides
from benchmarks.workdir import bench_workdir, cpu_description, read_iteration_records
from racer.local.run import LocalRunPlan, run_local_training
from racer.options.generation import generation_option
from racer.options.track import TRACK_HELP, direction_option
from racer.options.trainer import device_option
from racer.options.training import overlap_option, seed_option, workers_option
from racer.racing_line import CarLimits, LapTimeBoundError, RacingLine, racing_line
from racer.recipe.folder import Car, Recipe, RecipeError, make_recipe, write_recipe
from racer.shared.config import LocalStoreSettings, RedisSettings, ServiceSettings
from racer.shared.policy.manifest import CheckpointError
from racer.shared.run_settings import RunOptions, load_worker_settings
from racer.shared.sim.config import STEPS_PER_SECOND
from racer.shared.sim.generations.catalog import generation as generation_named
from racer.shared.sim.tracks.track import Track, TrackError
from racer.shared.store import open_store
from racer.shared.user_errors import user_error_types
from racer.trainer.device import DeviceError, describe_device, resolve_device
from racer.trainer.preset import PRESET_FILE

DEFAULT_TRACK = "reinvent_base"
"""re:Invent 2018, the track DeepRacer's console and the community have lap times for."""
DEFAULT_MINUTES = 20.0
"""An evening's training on two cores: the benchmark's goals are judged within it (docs/racing.md)."""
EVALUATION_LAPS = 3
SLOWEST_PACE_MPS = 1.0
"""The evaluation run's step cap is its 3 laps at this average speed: slower is no pace worth judging, and the cap
only stops a barely trained policy that circles on the road from holding worker 0 for minutes."""
MODEL_PREFIX = "race-pace"
ACTION_SPACES = ("discrete", "continuous")
KEPT_STORE = "kept"
"""The folder (beside the run's store) where the checkpoint of the lap to draw is copied before retention deletes it."""


@click.command(name="race-pace")
@click.option("--track", default=DEFAULT_TRACK, show_default=True, help=TRACK_HELP)
@direction_option
@click.option(
    "--minutes",
    type=click.FloatRange(min=0.0, min_open=True),
    default=DEFAULT_MINUTES,
    show_default=True,
    help="Wall time of the training run, its evaluations included.",
)
@click.option(
    "--action-space",
    type=click.Choice(ACTION_SPACES),
    default="discrete",
    show_default=True,
    help="`racer recipe`'s action space (docs/racing.md). Discrete: with clipped PPO on two cores racer's "
    "continuous models have not lapped in 20 minutes (docs/benchmarks.md, time to lap).",
)
@click.option(
    "--custom-files",
    type=click.Path(exists=True, file_okay=False, path_type=Path),
    default=None,
    help="Custom files instead of `racer recipe`'s (racer/defaults/racing/discrete: the fixed fast-lap recipe; "
    "--action-space is then theirs); the bench sets the evaluation keys of their workers.json.",
)
@workers_option
@click.option(
    "--hyperparameter",
    "hyperparameter_pairs",
    multiple=True,
    metavar="KEY=VALUE",
    help="A hyperparameters.json key over the recipe's (repeatable).",
)
@generation_option
@device_option
@overlap_option
@seed_option
@click.option(
    "--picture",
    type=click.Path(dir_okay=False, writable=True, path_type=Path),
    default=None,
    help="Draw the bound's racing line and the policy's best lap (driven again from its checkpoint) to this PNG; a "
    "completed lap's losses to the line per section and corner go into the JSON and a -losses PNG beside it.",
)
@click.option("--bound-only", is_flag=True, help="Compute the bound (and --picture: its line) and train nothing.")
def race_pace_command(
    track,
    minutes,
    action_space,
    custom_files,
    num_workers,
    hyperparameter_pairs,
    generation,
    device,
    overlap,
    seed,
    picture,
    bound_only,
):
    """Train from scratch for --minutes with the fast-lap recipe; judge each checkpoint on 3 consecutive greedy laps
    from the start line; print the best lap, the best 3-lap average, the curve, the car's lap-time bound and where
    the time went as one JSON line. It takes --generation's car and look and no other: the bound is that car's."""
    try:  # a GPU asked for and absent is refused before anything starts
        trainer_device = describe_device(resolve_device(device))
    except DeviceError as error:
        raise click.UsageError(str(error)) from error
    overrides = hyperparameter_overrides(hyperparameter_pairs)
    run = RunOptions(num_workers=num_workers, track=str(track), generation=generation, overlap=overlap)
    with bench_workdir("racer-race-pace-") as workdir:
        recipe = None if custom_files else _recipe(str(track), generation, run.worlds[0], action_space, workdir)
        source = custom_files or workdir / "recipe"
        custom = _bench_custom_files(source, workdir / "custom_files", overrides)
        try:
            evaluator = load_worker_settings(custom, run)[0]  # worker 0 evaluates: its car, world and track
            route = Track.load(evaluator.track)
        except (*user_error_types(), TrackError, ValueError) as error:
            raise click.ClickException(str(error)) from error
        route = route.reversed() if evaluator.reverse_dir else route
        _write_evaluation_keys(custom, route.length_m)
        click.echo(f"race-pace: the lap-time bound of the {generation} car on {route.name} ...", err=True)
        limits = CarLimits.of_car(evaluator.car_dynamics, world=evaluator.world)
        same_line = recipe is not None and recipe.line.limits == limits and recipe.line.track == route.name
        bound = recipe.line if same_line and not evaluator.reverse_dir else _bound(route, limits)
        click.echo(f"race-pace: bound {json.dumps(bound.summary())}", err=True)
        result: dict = {
            "track": route.name,
            "generation": generation,
            "car_profile": bound.limits.car_profile,
            "world": evaluator.world,
            "recipe": str(custom_files) if custom_files else f"racer recipe {track} --action-space {action_space}",
            "minutes": minutes,
            "workers": num_workers,
            "overlap": overlap,
            "seed": seed,
            "device": trainer_device,
            "cpu": cpu_description(),
            "cores": len(os.sched_getaffinity(0)),
            "bound": bound.summary(),
        }
        if bound_only:
            if picture is not None:
                result["picture"] = str(draw_pace(route, bound, None, _title(result, None), picture))
            click.echo(json.dumps(result))
            return
        plan = LocalRunPlan(
            model_prefix=MODEL_PREFIX,
            custom_files=custom,
            run=run,
            max_episodes=None,
            max_minutes=minutes,
            use_minio=False,
            log_dir=workdir / "logs",
            seed=seed,
            trainer_options=("--device", device),
        )
        trained = _train(plan, minutes, keep_to_draw=picture is not None)
        evaluations = trained.evaluations
        records = read_iteration_records(workdir / "store", plan)
        pace = pace_figures(evaluations)
        result.update(pace)
        result["evaluations_after_the_limit"] = trained.late
        result["ratio_to_bound"] = _ratios(pace, bound)
        result["iterations"] = len(records)
        result["env_steps_trained"] = records[-1]["env_steps_total"] if records else 0
        result["time_shares"] = time_shares(records, trained.cpu_s, trained.wall_s, result["cores"])
        result["hyperparameters"] = json.loads((custom / "hyperparameters.json").read_text())
        preset = custom / PRESET_FILE
        result["preset"] = json.loads(preset.read_text()) if preset.is_file() else None
        result["learning_rate"] = _learning_rates(records)
        result["kl_divergence"] = _kl_divergences(records)
        if picture is not None:
            result.update(_picture(route, bound, evaluations, pace, result, picture, workdir, seed))
        click.echo(json.dumps(result))


@dataclass(frozen=True)
class _Trained:
    evaluations: list[CheckpointLaps]
    """The checkpoint evaluations that arrived within --minutes, in order."""
    late: int
    """Evaluations that arrived after --minutes (the trainer's clock starts a little after the bench's): not counted."""
    cpu_s: float
    """CPU seconds of the run's processes (trainer, workers, Redis)."""
    wall_s: float


def _train(plan: LocalRunPlan, minutes: float, keep_to_draw: bool) -> _Trained:
    """Run the training; `keep_to_draw`: copy the checkpoint of the lap to draw aside as its evaluation arrives."""
    evaluations: list[CheckpointLaps] = []
    late = 0
    started = time.monotonic()
    run_store = open_store(LocalStoreSettings(root=plan.log_dir.parent / "store"))
    kept = open_store(LocalStoreSettings(root=plan.log_dir.parent / KEPT_STORE))

    def on_evaluation(record: dict) -> bool:
        nonlocal late
        elapsed_min = (time.monotonic() - started) / 60.0
        if elapsed_min > minutes:
            late += 1
            return True
        evaluations.append(CheckpointLaps.from_record(record, elapsed_min))
        target = lap_to_draw(evaluations)
        if keep_to_draw and target is not None and target.checkpoint == evaluations[-1].checkpoint:
            keep_checkpoint(run_store, kept, plan.model_prefix, target.checkpoint)
        best = min((e.best_lap_s for e in evaluations if e.best_lap_s), default=None)
        click.echo(
            f"race-pace: {elapsed_min:5.2f} min {record['checkpoint']}: laps {evaluations[-1].summary()['laps_s']}, "
            f"best lap so far {'none' if best is None else f'{best:.3f} s'}",
            err=True,
        )
        return False

    base = ServiceSettings(redis=RedisSettings(), store=LocalStoreSettings(root=plan.log_dir.parent / "store"))
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    with contextlib.redirect_stdout(sys.stderr):  # the run's progress lines: stdout is the bench's JSON line alone
        run_local_training(plan, base, on_evaluation=on_evaluation)
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu_s = sum(getattr(after, field) - getattr(before, field) for field in ("ru_utime", "ru_stime"))
    return _Trained(evaluations, late, cpu_s, time.monotonic() - started)


def _recipe(track: str, generation: str, world: str, action_space: str, workdir: Path) -> Recipe:
    """`racer recipe`'s folder for the judged track and the generation's car, written to workdir/recipe."""
    car = Car(dynamics=generation_named(generation).car, generation=generation, car_profile="", world=world)
    try:
        recipe = make_recipe(Track.load(track), car, action_space, route_name=track)
    except (RecipeError, TrackError) as error:
        raise click.ClickException(str(error)) from error
    write_recipe(recipe, workdir / "recipe")
    click.echo(f"race-pace: racer recipe {track}: {json.dumps(recipe.summary()['action_space'])}", err=True)
    return recipe


def _bench_custom_files(source: Path, folder: Path, overrides: dict) -> Path:
    """The run's custom files: the recipe's (or the user's) with --hyperparameter over them."""
    shutil.copytree(source, folder, ignore=shutil.ignore_patterns("__pycache__"))
    if overrides:
        path = folder / "hyperparameters.json"
        path.write_text(json.dumps({**json.loads(path.read_text()), **overrides}, indent=4))
    return folder


def _write_evaluation_keys(folder: Path, track_length_m: float) -> None:
    """The evaluation the bench judges, over whatever workers.json the custom files bring: 3 consecutive laps from
    the start line, capped at 3 laps' steps at SLOWEST_PACE_MPS."""
    path = folder / "workers.json"
    workers = json.loads(path.read_text()) if path.is_file() else {}
    cap_steps = math.ceil(EVALUATION_LAPS * track_length_m / SLOWEST_PACE_MPS * STEPS_PER_SECOND)
    workers.update(MIN_EVAL_TRIALS=EVALUATION_LAPS, RACER_EVAL_CONTINUOUS="True", RACER_EVAL_MAX_STEPS=cap_steps)
    path.write_text(json.dumps(workers, indent=4))


def _bound(route: Track, limits: CarLimits) -> RacingLine:
    try:
        return racing_line(route, limits)
    except LapTimeBoundError as error:
        raise click.ClickException(str(error)) from error


def _ratios(pace: dict, bound: RacingLine) -> dict:
    """The policy against the bound: its best 3-lap average over the bound's 3 laps from rest, its best lap over the
    bound's flying lap (a best lap may be a flying one)."""
    average, lap = pace["best_three_lap_average"], pace["best_lap"]
    return {
        "best_three_lap_average": None if average is None else round(average["seconds"] / bound.standing_average_s, 3),
        "best_lap": None if lap is None else round(lap["seconds"] / bound.lap_time_s, 3),
    }


def _learning_rates(records: list[dict]) -> dict | None:
    """The learning rate after the first and the last update, and its range (a preset's desired_kl moves it)."""
    rates = [record["learning_rate"] for record in records if "learning_rate" in record]
    if not rates:
        return None
    return {"first": rates[0], "last": rates[-1], "lowest": min(rates), "highest": max(rates)}


def _kl_divergences(records: list[dict]) -> dict | None:
    """The updates' KL(old || new), each a mean over its epochs: the median and the largest over the run."""
    kls = sorted(record["kl_divergence"] for record in records if record.get("kl_divergence") is not None)
    if not kls:
        return None
    return {"median": kls[len(kls) // 2], "highest": kls[-1]}


def _title(result: dict, pace: dict | None) -> str:
    text = f"{result['track']}, {result['generation']} car ({result['car_profile']}), {result['world']} world"
    if pace is not None and pace["best_three_lap_average"] is not None:
        average = pace["best_three_lap_average"]
        text += f": best 3-lap average {average['seconds']:.2f} s after {average['minutes']:.1f} min"
    return text


def _picture(
    route: Track,
    bound: RacingLine,
    evaluations: list[CheckpointLaps],
    pace: dict,
    result: dict,
    path: Path,
    workdir: Path,
    seed: int,
) -> dict:
    """Draw the bound's line and the best lap (before any lap: the furthest drive), driven again from its checkpoint;
    say whether the drive matched the evaluation (racer's simulator is deterministic); a completed lap's losses to
    the line per section and corner, and their picture beside `path` (-losses)."""
    target = lap_to_draw(evaluations)
    driven = None
    found: dict = {}
    if target is not None:
        run_store = open_store(LocalStoreSettings(root=workdir / "store"))
        kept = open_store(LocalStoreSettings(root=workdir / KEPT_STORE))
        try:
            driven = drive_lap_again(
                run_store, kept, MODEL_PREFIX, target.checkpoint, target.lap_index, workdir / "replay", seed
            )
        except CheckpointError as error:  # deleted by retention before the bench could copy it: drawn without it
            draw_pace(route, bound, None, _title(result, pace), path)
            return {"picture": str(path), "picture_lap": {"checkpoint": target.checkpoint, "error": str(error)}}
        found["picture_lap"] = {
            "checkpoint": target.checkpoint,
            "lap": target.lap_index + 1,
            "lap_s": None if driven.lap_time_s is None else round(driven.lap_time_s, 3),
            "progress": round(driven.progress, 3),
            "matches_the_evaluation": _same(driven.lap_time_s, target.lap_time_s)
            and _same(driven.progress, target.progress),
        }
    draw_pace(route, bound, driven, _title(result, pace), path)
    against = None if driven is None else lap_against_line(route, bound, driven)
    if against is not None:
        found["lap_against_line"] = loss_summary(against, path.with_name(f"{path.stem}-losses{path.suffix}"))
    return {"picture": str(path), **found}


def _same(a: float | None, b: float | None) -> bool:
    """Equal to the evaluation's rounding (progress is recorded to 0.001 %)."""
    return (a is None and b is None) or (a is not None and b is not None and abs(a - b) < 2e-3)
