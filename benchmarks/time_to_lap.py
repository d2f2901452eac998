"""`python -m benchmarks time-to-lap`: train from scratch with `racer train`'s processes until greedy evaluation drives 3 of 3
laps, and print how long it took (minutes, env steps, the CPU the run used) as one JSON line."""

from __future__ import annotations

import json
import os
import resource
import time
from collections.abc import Sequence
from pathlib import Path

import click

from benchmarks.deepracer_data import data_folder, data_option
from benchmarks.time_to_lap_race_types import RACE_TYPE_SETUPS, time_to_lap_hyperparameters
from benchmarks.workdir import bench_workdir, cpu_description, read_iteration_records
from racer.local.run import LocalRunPlan, run_local_training
from racer.options.track import direction_option, track_option
from racer.options.trainer import trainer_run_options
from racer.options.training import overlap_option, seed_option, workers_option
from racer.shared.config import LocalStoreSettings, RedisSettings, ServiceSettings
from racer.shared.deepracer.hyperparameters import HyperparametersError, parse_hyperparameters
from racer.shared.run_settings import RunOptions
from racer.shared.sim.scene.worlds import WORLD_NAMES as WORLDS
from racer.trainer.device import DeviceError, describe_device, resolve_device


@click.command(name="time-to-lap")
@track_option(required=True)
@direction_option
@click.option(
    "--reward-function",
    type=click.Path(exists=True, dir_okay=False, path_type=Path),
    default=None,
    help="Default: the race type's example from reward_functions/ of --data (the time trial's: AWS 'follow the "
    "centre line').",
)
@click.option(
    "--algorithm",
    type=click.Choice(["clipped_ppo", "sac"]),
    default="clipped_ppo",
    show_default=True,
    help="training_algorithm of the model (SAC: continuous only).",
)
@click.option(
    "--action-space",
    type=click.Choice(["discrete", "continuous"]),
    default=None,
    help="Default: discrete for clipped_ppo (5 steering angles at --speed), continuous for sac "
    "(steering -30..30 deg, speed --min-speed..--max-speed).",
)
@click.option("--speed", type=float, default=1.0, show_default=True, help="The one speed (m/s) of the 5 actions.")
@click.option("--min-speed", type=float, default=1.0, show_default=True, help="Continuous: lowest speed (m/s).")
@click.option("--max-speed", type=float, default=2.0, show_default=True, help="Continuous: highest speed (m/s).")
@workers_option
@click.option("--time-limit-minutes", type=float, default=30.0, show_default=True)
@click.option(
    "--episodes-per-iteration",
    type=int,
    default=None,
    help="num_episodes_between_training (default: the race type's recipe, else DeepRacer's 20).",
)
@click.option(
    "--sac-updates-per-transition",
    type=float,
    default=None,
    help="SAC: gradient steps per transition [default: the --preset's updates_per_transition, else 0.15]. DeepRacer "
    "takes 1, which on two CPU cores leaves the trainer far behind the workers (see `python -m benchmarks sac` and the "
    "README's benchmark section).",
)
@click.option(
    "--race-type",
    type=click.Choice(list(RACE_TYPE_SETUPS)),
    default="time-trial",
    show_default=True,
    help="object-avoidance: 3 boxes at fixed places (OBJECT_POSITIONS 0.23,-1;0.46,1;0.67,-1); head-to-bot: 2 bot "
    "cars at 0.5 m/s changing lanes. Both default to DeepRacer's object-avoidance / head-to-head sample reward.",
)
@click.option(
    "--sensors",
    type=click.Choice(["camera", "stereo-lidar"]),
    default="camera",
    show_default=True,
    help="camera: FRONT_FACING_CAMERA (one frame per step, the cheapest on CPU); stereo-lidar: STEREO_CAMERAS + LIDAR "
    "(DeepRacer's recommendation for racing against objects; two frames and 64 rays per step).",
)
@click.option(
    "--hyperparameter",
    "hyperparameter_pairs",
    multiple=True,
    metavar="KEY=VALUE",
    help="A hyperparameters.json key over the recipe and the SimApp defaults (repeatable), e.g. sac_alpha=0.05.",
)
@click.option(
    "--network",
    "network_file",
    type=click.Path(exists=True, dir_okay=False, path_type=Path),
    default=None,
    help="Your own network.json (docs/custom-networks.md); the model's neural_network becomes its name.",
)
@click.option(
    "--preset",
    "preset_file",
    type=click.Path(exists=True, dir_okay=False, path_type=Path),
    default=None,
    help="A preset.json (docs/custom-networks.md).",
)
@trainer_run_options
@overlap_option
@seed_option
@data_option
def time_to_lap_command(
    track,
    reward_function,
    algorithm,
    action_space,
    speed,
    min_speed,
    max_speed,
    num_workers,
    time_limit_minutes,
    episodes_per_iteration,
    sac_updates_per_transition,
    race_type,
    sensors,
    hyperparameter_pairs,
    network_file,
    preset_file,
    device,
    precision,
    car_profile,
    generation,
    dynamics_randomization,
    overlap,
    seed,
    data_dir,
):
    """Train from scratch until greedy evaluation completes 3 of 3 laps (from three starts a third of a lap
    apart); print one JSON line. Hyperparameters: the race type's clipped-PPO recipe (3 epochs, discount 0.99), else
    the SimApp's defaults."""

    try:  # a GPU asked for and absent is refused before anything starts
        trainer_device = describe_device(resolve_device(device))
    except DeviceError as error:
        raise click.UsageError(str(error)) from error
    overrides = hyperparameter_overrides(hyperparameter_pairs)
    action_space = action_space or ("continuous" if algorithm == "sac" else "discrete")
    if algorithm == "sac" and action_space != "continuous":
        raise click.UsageError("--algorithm sac needs --action-space continuous (DeepRacer's SAC is continuous only)")
    setup = RACE_TYPE_SETUPS[race_type]
    reward_function = reward_function or data_folder(data_dir) / "reward_functions" / setup.reward_function
    if not Path(reward_function).is_file():
        raise click.UsageError(f"reward function not found: {reward_function}; pass --reward-function")
    with bench_workdir("racer-time-to-lap-") as workdir:
        custom = workdir / "custom_files"
        custom.mkdir()
        (custom / "reward_function.py").write_bytes(Path(reward_function).read_bytes())
        if action_space == "continuous":
            actions: object = {
                "steering_angle": {"low": -30, "high": 30},
                "speed": {"low": min_speed, "high": max_speed},
            }
        else:
            actions = [
                {"steering_angle": angle, "speed": speed, "index": i} for i, angle in enumerate([-30, -15, 0, 15, 30])
            ]
        network_name = "DEEP_CONVOLUTIONAL_NETWORK_SHALLOW"
        if network_file is not None:
            # The preflight checks the file and names what is wrong with it, a missing name included.
            network_name = str(json.loads(network_file.read_text()).get("name", "NETWORK_WITHOUT_NAME"))
            (custom / "network.json").write_bytes(network_file.read_bytes())
        if preset_file is not None:
            (custom / "preset.json").write_bytes(preset_file.read_bytes())
        ratio_options: tuple[str, ...] = ()  # the trainer refuses a ratio given here and differently in the preset
        preset_data = json.loads(preset_file.read_text()) if preset_file is not None else None
        preset_ratio = preset_data.get("updates_per_transition") if isinstance(preset_data, dict) else None
        if sac_updates_per_transition is not None or preset_ratio is None:
            sac_updates_per_transition = sac_updates_per_transition or 0.15
            ratio_options = ("--sac-updates-per-transition", str(sac_updates_per_transition))
        else:
            sac_updates_per_transition = preset_ratio
        (custom / "model_metadata.json").write_text(
            json.dumps(
                {
                    "action_space": actions,
                    "action_space_type": action_space,
                    "sensor": ["FRONT_FACING_CAMERA"] if sensors == "camera" else ["STEREO_CAMERAS", "LIDAR"],
                    "neural_network": network_name,
                    "training_algorithm": algorithm,
                    "version": "5",
                }
            )
        )
        hyperparameters = time_to_lap_hyperparameters(race_type, algorithm, episodes_per_iteration)
        hyperparameters.update(overrides)  # --hyperparameter wins over the recipe
        (custom / "hyperparameters.json").write_text(json.dumps(hyperparameters))
        # Three greedy laps from three places on the lap (0, 1/3, 2/3 on from the round-robin start): the simulator is
        # deterministic, so three trials from one place would be one drive three times.
        (custom / "workers.json").write_text(json.dumps({"MIN_EVAL_TRIALS": 3, "RACER_EVAL_SPREAD_STARTS": "True"}))
        plan = LocalRunPlan(
            model_prefix="time-to-lap",
            custom_files=custom,
            run=RunOptions(
                num_workers=num_workers,
                track=str(track),
                worlds=WORLDS,
                car_profile=car_profile,
                generation=generation,
                dynamics_randomization=dynamics_randomization,
                challenge_params=setup.challenge_params,
                overlap=overlap,
            ),
            max_episodes=None,
            max_minutes=time_limit_minutes,
            use_minio=False,
            log_dir=workdir / "logs",
            seed=seed,
            trainer_options=(*ratio_options, "--precision", precision, "--device", device),
        )
        result = {
            "race_type": race_type,
            "sensors": sensors,
            "algorithm": algorithm,
            "action_space": action_space,
            "precision": precision,
            "device": trainer_device,
            "network": network_name,
            "preset": json.loads(preset_file.read_text()) if preset_file is not None else None,
            "generation": generation,
            "car_profile": car_profile,
            "dynamics_randomization": dynamics_randomization,
            "overlap": overlap,
            "cpu": cpu_description(),
            "minutes": None,
            "env_steps": None,
            "iterations": None,
            "hyperparameters": hyperparameters,
        }
        if algorithm == "sac":
            result["sac_updates_per_transition"] = sac_updates_per_transition
        started = time.monotonic()
        rates: list[float] = []

        best_progress: list[float] = []
        load_averages: list[float] = []  # the machine may be shared: the 1-minute load at every evaluation

        def on_evaluation(record: dict) -> bool:
            best_progress.append(float(record["mean_progress"]))
            load_averages.append(os.getloadavg()[0])
            if record["trials"] >= 3 and record["laps_completed"] >= 3 and result["minutes"] is None:
                result.update(
                    minutes=round((time.monotonic() - started) / 60, 2),
                    env_steps=record["env_steps_total"],
                    iterations=record["iteration"],
                )
                return True
            return False

        base = ServiceSettings(redis=RedisSettings(), store=LocalStoreSettings(root=workdir / "store"))
        children_before = resource.getrusage(resource.RUSAGE_CHILDREN)
        run_local_training(plan, base, on_evaluation=on_evaluation)
        children_after = resource.getrusage(resource.RUSAGE_CHILDREN)
        channel_records = read_iteration_records(workdir / "store", plan)
        rates = [r["experience_steps_per_s"] for r in channel_records]
        result["experience_steps_per_s"] = round(sum(rates) / len(rates), 1) if rates else None
        # When the goal is not reached, how far it got: iterations trained and the best greedy evaluation.
        result["iterations_trained"] = len(channel_records)
        result["env_steps_trained"] = channel_records[-1]["env_steps_total"] if channel_records else 0
        result["best_evaluation_progress_pct"] = round(max(best_progress), 1) if best_progress else None
        result["mean_load_average_1min"] = round(sum(load_averages) / len(load_averages), 2) if load_averages else None
        # CPU the run's processes used (trainer, workers, Redis), to the end of the run: on a machine shared with other
        # work, cpu_minutes / cores is a floor for the wall time the same run would take alone.
        cpu_s = sum(
            getattr(children_after, field) - getattr(children_before, field) for field in ("ru_utime", "ru_stime")
        )
        result["cpu_minutes"] = round(cpu_s / 60, 2)
        result["cores"] = len(os.sched_getaffinity(0))
        result["track"] = str(track)
        click.echo(json.dumps(result))


def hyperparameter_overrides(pairs: Sequence[str]) -> dict[str, object]:
    """`KEY=VALUE` pairs as hyperparameters.json entries (VALUE read as JSON, else as text), checked as the trainer
    will check them."""
    overrides: dict[str, object] = {}
    for pair in pairs:
        key, separator, text = pair.partition("=")
        if not separator or not key:
            raise click.BadParameter(f"{pair!r} is not KEY=VALUE", param_hint="--hyperparameter")
        try:
            overrides[key.strip()] = json.loads(text)
        except json.JSONDecodeError:
            overrides[key.strip()] = text.strip()
    try:
        _, warnings = parse_hyperparameters(overrides, source="--hyperparameter")
    except HyperparametersError as error:
        raise click.BadParameter(str(error), param_hint="--hyperparameter") from error
    if warnings:
        raise click.BadParameter("; ".join(warnings), param_hint="--hyperparameter")
    return overrides
