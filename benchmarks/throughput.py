"""`python -m benchmarks throughput`: the default system's experience rate against the machine's bound, in one run.

system: `racer train` as shipped (default workers, envs per worker, custom files, track; no viewer) for a fixed
number of iterations. Its experience rate is the one the display prints: the training steps of an iteration over
the time from the iteration's announcement until its last episode arrived, summed over the iterations after the
first (the first includes building the envs). The end-to-end rate (the same steps over the wall time of those
iterations, update and checkpoint included) is printed beside it.
bound: one process per core (os.sched_getaffinity) running `python -m benchmarks sim`'s raw loop (physics and the 160x120
camera, no env code, no policy) at the same time, measured before and after the system, averaged.
ceilings: what the ratio could be at best: the bound's CPU per step against the same plus the policy's forward pass
per frame (the default model's ONNX session as the workers run it, at their batch of `--envs`, timed in this
process before the system starts), then plus the env code too (reward params, reward function, simtrace row: the
env step's CPU over the raw loop's, timed in alternating blocks). Every other cost of the system (recording,
encoding, Redis, checkpoint loading, the trainer, idle envs at the end of a rollout) comes on top, so the measured
ratio stays below both.
"""

from __future__ import annotations

import json
import os
import resource
import subprocess
import sys
import time

import click

from benchmarks.workdir import bench_workdir, read_iteration_records
from racer.defaults import DEFAULT_CUSTOM_FILES
from racer.local.run import LocalRunPlan, run_local_training, service_environment
from racer.rollout_worker.envs import DEFAULT_ENVS_PER_WORKER, default_workers
from racer.shared.config import LocalStoreSettings, RedisSettings, ServiceSettings
from racer.shared.deepracer.hyperparameters import load_hyperparameters
from racer.shared.run_settings import RunOptions
from racer.shared.sim.config import DEFAULT_TRACK
from racer.shared.sim.scene.worlds import WORLD_NAMES

BOUND_START_DELAY_S = 20.0
"""Time the bound's processes get to build their scene before all start measuring together."""


def machine_bound(processes: int, duration_s: float, settings: ServiceSettings) -> dict:
    """Raw env steps/s of `processes` processes running at once (environment as the rollout workers get it)."""
    start_at = time.time() + BOUND_START_DELAY_S
    code = f"from benchmarks.sim import raw_rate_child; raw_rate_child({start_at!r}, {duration_s!r}, seed={{seed}})"
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
    from benchmarks.sim import run_benchmark

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


def system_rates(records: list[dict]) -> dict:
    """Experience and end-to-end rates of the iterations after the first."""
    later = records[1:]
    if not later:
        raise click.ClickException("the run finished fewer than 2 iterations; nothing to measure after the warm-up")
    steps = [r["env_steps_total"] - previous["env_steps_total"] for previous, r in zip(records, later, strict=False)]
    rollout_s = [step / max(r["experience_steps_per_s"], 1e-9) for step, r in zip(steps, later, strict=True)]
    wall_s = later[-1]["elapsed_s"] - records[0]["elapsed_s"]
    update_s = sum(r.get("update_s", 0.0) for r in later)
    return {
        "update_share_of_wall": update_s / wall_s,
        "experience_steps_per_s": sum(steps) / sum(rollout_s),
        "end_to_end_steps_per_s": sum(steps) / wall_s,
        "rollout_share_of_wall": sum(rollout_s) / wall_s,
        "steps_measured": sum(steps),
    }


@click.command("throughput")
@click.option("--iterations", type=click.IntRange(2, 1000), default=5, show_default=True)
@click.option("--workers", "num_workers", type=click.IntRange(1, 32), default=default_workers(), show_default=True)
@click.option(
    "--envs", "envs_per_worker", type=click.IntRange(1, 64), default=DEFAULT_ENVS_PER_WORKER, show_default=True
)
@click.option("--bound-seconds", type=float, default=20.0, show_default=True, help="Length of each bound measurement.")
@click.option("--seed", type=int, default=0, show_default=True)
def throughput_bench_command(iterations, num_workers, envs_per_worker, bound_seconds, seed) -> None:
    """The default system's experience steps/s vs one raw env process per core; prints one JSON line."""
    cores = len(os.sched_getaffinity(0))
    with bench_workdir("racer-throughput-") as workdir:
        base = ServiceSettings(redis=RedisSettings(), store=LocalStoreSettings(root=workdir / "store"))
        custom = DEFAULT_CUSTOM_FILES
        episodes = load_hyperparameters(custom / "hyperparameters.json")[0].num_episodes_between_training
        click.echo("ceilings: raw loop, env step and the policy's forward pass, one after the other ...", err=True)
        costs = per_step_costs(envs_per_worker)
        click.echo(f"bound: {cores} raw env processes for {bound_seconds:.0f} s ...", err=True)
        before = machine_bound(cores, bound_seconds, base)
        plan = LocalRunPlan(
            model_prefix="throughput",
            custom_files=custom,
            run=RunOptions(num_workers=num_workers, track=DEFAULT_TRACK, worlds=WORLD_NAMES),
            max_episodes=iterations * episodes,
            max_minutes=None,
            use_minio=False,
            log_dir=workdir / "logs",
            seed=seed,
            envs_per_worker=envs_per_worker,
        )
        click.echo(f"system: {num_workers} workers x {envs_per_worker} envs, {iterations} iterations ...", err=True)
        children_before = resource.getrusage(resource.RUSAGE_CHILDREN)
        status = run_local_training(plan, base)
        children_after = resource.getrusage(resource.RUSAGE_CHILDREN)
        system_cpu_s = (children_after.ru_utime + children_after.ru_stime) - (
            children_before.ru_utime + children_before.ru_stime
        )
        if status != 0:
            raise click.ClickException(f"the training run failed (status {status}); logs in {plan.log_dir}")
        records = read_iteration_records(workdir / "store", plan)
        rates = system_rates(records)
        click.echo(f"bound again for {bound_seconds:.0f} s ...", err=True)
        after = machine_bound(cores, bound_seconds, base)
        bound = (before["steps_per_s"] + after["steps_per_s"]) / 2
        bound_cpu_ms = (before["cpu_ms_per_step"] + after["cpu_ms_per_step"]) / 2
        result = {
            "experience_steps_per_s": round(rates["experience_steps_per_s"], 1),
            "bound_steps_per_s": round(bound, 1),
            "ratio": round(rates["experience_steps_per_s"] / bound, 3),
            **costs,
            **ratio_ceilings(bound_cpu_ms, costs),
            "end_to_end_steps_per_s": round(rates["end_to_end_steps_per_s"], 1),
            "rollout_share_of_wall": round(rates["rollout_share_of_wall"], 3),
            "update_share_of_wall": round(rates["update_share_of_wall"], 3),
            # CPU seconds per training step of every process of the run (trainer, workers, Redis; start-up, updates and
            # evaluations included) against the bound's: less sensitive than wall rates to other load on the machine.
            "system_cpu_ms_per_step": round(1e3 * system_cpu_s / max(1, records[-1]["env_steps_total"]), 3),
            "bound_cpu_ms_per_step": round(bound_cpu_ms, 3),
            "bound_before_after_steps_per_s": [round(before["steps_per_s"], 1), round(after["steps_per_s"], 1)],
            "bound_processes": cores,
            "workers": num_workers,
            "envs_per_worker": envs_per_worker,
            "iterations": iterations,
            "steps_measured": rates["steps_measured"],
            "load_average_1min": round(os.getloadavg()[0], 2),
        }
        click.echo(json.dumps(result))
