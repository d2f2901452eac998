"""`python -m benchmarks throughput`: the system's training rate in both modes (DeepRacer's strict alternation and
`--overlap`) in one invocation, against the machine's bound.

system: `racer train` (the custom files, envs per worker and track given; no viewer) for a fixed number of
iterations, once strict and once overlapped, for each `--workers` count (benchmarks.throughput_modes). Each mode's
`end_to_end_env_steps_per_s` is the env steps trained over the wall time of the iterations after the first (the first
includes building the envs), update and checkpoints included; `cpu_busy` and `time_shares` are the race-pace bench's
measures over the same window. Its experience rate (what the display prints: training steps over the time from an
iteration's announcement until its last episode arrived) is beside them. The top-level figures of earlier versions
(`experience_steps_per_s`, `ratio`, `end_to_end_steps_per_s`, ...) are strict's at the first worker count.
bound: one process per core (os.sched_getaffinity) running `python -m benchmarks sim`'s raw loop (physics and the 160x120
camera, no env code, no policy) at the same time, measured before and after the runs, averaged.
ceilings: what the ratio could be at best: the bound's CPU per step against the same plus the policy's forward pass
per frame (the default model's ONNX session as the workers run it, at their batch of `--envs`, timed in this
process before the system starts), then plus the env code too (reward params, reward function, simtrace row: the
env step's CPU over the raw loop's, timed in alternating blocks). Every other cost of the system (recording,
encoding, Redis, checkpoint loading, the trainer, idle envs at the end of a rollout) comes on top, so the measured
ratio stays below both. `--bound-seconds 0` measures neither (the modes only).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

import click

from benchmarks.throughput_modes import MODES, mode_figures, train_one_mode
from benchmarks.workdir import bench_workdir, cpu_description
from racer.defaults import DEFAULT_CUSTOM_FILES
from racer.local.run import LocalRunPlan, service_environment
from racer.options.trainer import device_option
from racer.options.training import envs_option, seed_option
from racer.shared.config import LocalStoreSettings, RedisSettings, ServiceSettings
from racer.shared.deepracer.hyperparameters import load_hyperparameters
from racer.shared.run_settings import RunOptions
from racer.shared.sim.config import DEFAULT_TRACK
from racer.shared.sim.scene.worlds import WORLD_NAMES
from racer.trainer.device import DeviceError, describe_device, resolve_device


def workers_for_every_core() -> int:
    """The bench's rollout workers: one per core at least, so every core has envs to step; four at least, one per
    world. (`racer train`'s default is the same on every machine: racer.options.training.DEFAULT_WORKERS.)"""
    return max(4, len(os.sched_getaffinity(0)))


BOUND_START_DELAY_S = 20.0
"""Time the bound's processes get to build their scene before all start measuring together."""


def machine_bound(processes: int, duration_s: float, settings: ServiceSettings) -> dict:
    """Raw env steps/s of `processes` processes running at once (environment as the rollout workers get it)."""
    start_at = time.time() + BOUND_START_DELAY_S
    code = f"from benchmarks.sim_measure import raw_rate_child; raw_rate_child({start_at!r}, {duration_s!r}, seed={{seed}})"
    children = [
        subprocess.Popen(
            [sys.executable, "-c", code.format(seed=index)],
            stdout=subprocess.PIPE,
            text=True,
            env=service_environment(settings),
        )
        for index in range(processes)
    ]
    rates = []
    for child in children:
        out, _ = child.communicate(timeout=BOUND_START_DELAY_S + duration_s + 120)
        if child.returncode != 0:
            raise click.ClickException(f"a raw-bound process failed with status {child.returncode}")
        rates.append(json.loads(out.strip().splitlines()[-1]))
    return {
        "steps_per_s": sum(r["steps_per_s"] for r in rates),
        "cpu_ms_per_step": sum(r["cpu_ms_per_step"] for r in rates) / len(rates),
    }


def policy_forward_cpu_ms(envs_per_worker: int, frames: int = 400) -> float:
    """CPU ms per frame of the default model's forward pass (fresh weights) at the workers' batch size."""
    import numpy as np
    import torch

    from racer.shared.deepracer.model_metadata import load_model_metadata
    from racer.shared.policy.networks import build_actor_critic
    from racer.shared.policy.onnx_export import export_onnx
    from racer.shared.policy.onnx_policy import OnnxPolicy

    torch.manual_seed(0)
    network = build_actor_critic(load_model_metadata(DEFAULT_CUSTOM_FILES / "model_metadata.json")).eval()
    policy = OnnxPolicy(export_onnx(network), network.config)
    rng = np.random.default_rng(0)
    batch = [
        {spec.name: rng.integers(0, 256, size=spec.shape, dtype=np.uint8) for spec in network.config.inputs}
        for _ in range(envs_per_worker)
    ]
    calls = max(1, frames // envs_per_worker)
    policy.policy_outputs(batch)
    cpu_start = time.process_time()
    for _ in range(calls):
        policy.policy_outputs(batch)
    return 1e3 * (time.process_time() - cpu_start) / (calls * envs_per_worker)


def per_step_costs(envs_per_worker: int) -> dict:
    """CPU ms per step of the policy's forward pass and of the env code beyond the raw loop (the env step and the raw
    loop measured in alternating blocks in this process, so their difference holds when the machine is busy)."""
    from benchmarks.sim_measure import run_benchmark

    sim = run_benchmark(steps=1800)
    return {
        "policy_forward_cpu_ms_per_frame": round(policy_forward_cpu_ms(envs_per_worker), 3),
        "env_code_cpu_ms_per_step": round(sim["env_cpu_ms_per_step"] - sim["raw_cpu_ms_per_step"], 3),
    }


def ratio_ceilings(bound_cpu_ms_per_step: float, costs: dict) -> dict:
    """The best ratios the system could reach if nothing but the bound's raw loop and the policy's forward pass (and
    then also the env code: reward params, reward function, simtrace row) cost CPU."""
    raw_ms, forward_ms = bound_cpu_ms_per_step, costs["policy_forward_cpu_ms_per_frame"]
    return {
        "ratio_ceiling_raw_plus_policy": round(raw_ms / (raw_ms + forward_ms), 3),
        "ratio_ceiling_env_plus_policy": round(raw_ms / (raw_ms + costs["env_code_cpu_ms_per_step"] + forward_ms), 3),
    }


def worker_counts(ctx: click.Context, param: click.Parameter, value: str) -> tuple[int, ...]:
    """`--workers 1,2,4`: each count from 1 to 32, in the order given."""
    try:
        counts = tuple(int(item) for item in value.split(","))
    except ValueError:
        raise click.BadParameter(f"{value!r} is not a comma-separated list of worker counts, e.g. 1,2,4") from None
    if not counts or any(not 1 <= count <= 32 for count in counts) or len(set(counts)) != len(counts):
        raise click.BadParameter(f"{value!r}: each worker count once, from 1 to 32")
    return counts


@click.command("throughput")
@click.option("--iterations", type=click.IntRange(2, 1000), default=5, show_default=True)
@click.option(
    "--workers",
    "worker_counts_",
    default=str(workers_for_every_core()),
    show_default=True,
    callback=worker_counts,
    help="Rollout workers: by default one per core, four at least. A comma list (1,2,4) runs both modes at each "
    "count and adds `by_workers`.",
)
@envs_option
@click.option(
    "--custom-files",
    type=click.Path(exists=True, file_okay=False, path_type=Path),
    default=DEFAULT_CUSTOM_FILES,
    show_default=True,
    help="The model to train (its hyperparameters set the episodes per iteration).",
)
@click.option(
    "--bound-seconds",
    type=click.FloatRange(min=0.0),
    default=20.0,
    show_default=True,
    help="Length of each bound measurement; 0: no bound and no ceilings.",
)
@device_option
@seed_option
def throughput_bench_command(
    iterations, worker_counts_, envs_per_worker, custom_files, bound_seconds, device, seed
) -> None:
    """Both modes' end-to-end env steps/s and cpu_busy (and the experience steps/s vs one raw env process per core);
    prints one JSON line."""
    try:  # a GPU asked for and absent is refused before anything starts
        trainer_device = describe_device(resolve_device(device))
    except DeviceError as error:
        raise click.UsageError(str(error)) from error
    cores = len(os.sched_getaffinity(0))
    with bench_workdir("racer-throughput-") as workdir:
        base = ServiceSettings(redis=RedisSettings(), store=LocalStoreSettings(root=workdir / "store"))
        episodes = load_hyperparameters(custom_files / "hyperparameters.json")[0].num_episodes_between_training
        costs, before = {}, None
        if bound_seconds > 0:
            click.echo("ceilings: raw loop, env step and the policy's forward pass, one after the other ...", err=True)
            costs = per_step_costs(envs_per_worker)
            click.echo(f"bound: {cores} raw env processes for {bound_seconds:.0f} s ...", err=True)
            before = machine_bound(cores, bound_seconds, base)
        by_workers = []
        for num_workers in worker_counts_:
            plan = LocalRunPlan(
                model_prefix="throughput",
                custom_files=custom_files,
                run=RunOptions(num_workers=num_workers, track=DEFAULT_TRACK, worlds=WORLD_NAMES),
                max_episodes=iterations * episodes,
                max_minutes=None,
                use_minio=False,
                log_dir=workdir / "logs",
                seed=seed,
                envs_per_worker=envs_per_worker,
                trainer_options=("--device", device),
            )
            modes = {}
            for overlap in (False, True):
                click.echo(
                    f"system, {MODES[overlap]}: {num_workers} workers x {envs_per_worker} envs, {iterations} "
                    "iterations ...",
                    err=True,
                )
                modes[MODES[overlap]] = mode_figures(train_one_mode(plan, overlap, workdir), cores)
            by_workers.append({"workers": num_workers, "modes": modes, **_overlap_over_strict(modes)})
        result = {
            "modes": by_workers[0]["modes"],
            **_overlap_over_strict(by_workers[0]["modes"]),
            **_strict_top_level(by_workers[0]["modes"]["strict"]),
        }
        if before is not None:
            click.echo(f"bound again for {bound_seconds:.0f} s ...", err=True)
            after = machine_bound(cores, bound_seconds, base)
            result.update(_bound_figures(before, after, costs, result["experience_steps_per_s"]))
        result.update(
            workers=worker_counts_[0],
            envs_per_worker=envs_per_worker,
            iterations=iterations,
            device=trainer_device,
            cpu=cpu_description(),
            cores=cores,
            load_average_1min=round(os.getloadavg()[0], 2),
        )
        if len(worker_counts_) > 1:
            result["by_workers"] = by_workers
        click.echo(json.dumps(result))


def _overlap_over_strict(modes: dict) -> dict:
    strict, overlap = (modes[mode]["end_to_end_env_steps_per_s"] for mode in MODES)
    return {"overlap_over_strict_end_to_end": round(overlap / strict, 3) if strict > 0 else None}


def _strict_top_level(strict: dict) -> dict:
    """Strict's figures under the names this bench printed before it ran both modes."""
    keys = ("experience_steps_per_s", "rollout_share_of_wall", "update_share_of_wall", "system_cpu_ms_per_step")
    return {
        **{key: strict[key] for key in keys},
        "end_to_end_steps_per_s": strict["end_to_end_env_steps_per_s"],
        "steps_measured": strict["steps_measured"],
    }


def _bound_figures(before: dict, after: dict, costs: dict, experience_steps_per_s: float) -> dict:
    bound = (before["steps_per_s"] + after["steps_per_s"]) / 2
    bound_cpu_ms = (before["cpu_ms_per_step"] + after["cpu_ms_per_step"]) / 2
    return {
        "bound_steps_per_s": round(bound, 1),
        "ratio": round(experience_steps_per_s / bound, 3),
        **costs,
        **ratio_ceilings(bound_cpu_ms, costs),
        "bound_cpu_ms_per_step": round(bound_cpu_ms, 3),
        "bound_before_after_steps_per_s": [round(before["steps_per_s"], 1), round(after["steps_per_s"], 1)],
        "bound_processes": len(os.sched_getaffinity(0)),
    }
