"""`python -m benchmarks sim`: environment steps per second against the raw MuJoCo bound, measured in the same run.

env: `DeepRacerEnv` with the front camera at 160×120 on the default track (or `--track`), a real reward function (the DeepRacer
centre-line example, written to a temporary file) and uniformly random discrete actions.
raw bound: the same compiled scene, the same physics substeps (with the car's tyre model, `Car.step`: it is physics,
not env code) and one 160×120 render per step, no env code, through
the fastest render path we have (the env's lean `CameraRenderer` with the env's anti-aliasing; without it the
renderer is pixel-identical to `mujoco.Renderer`, and its flush alone makes a bare physics+render loop faster).
The two are measured in alternating blocks so that load from other processes hits both alike; process CPU
time per step is reported too, since wall-clock rates on a shared 2-core machine move with everyone's load.
"""

from __future__ import annotations

import json
import tempfile
import time
from pathlib import Path

import click
import numpy as np

from benchmarks.sim_loop import BENCH_REWARD, env_block
from benchmarks.sim_race_types import run_race_type_benchmark
from racer.options.track import direction_option
from racer.shared.sim.config import DEFAULT_TRACK, EnvConfig
from racer.shared.sim.env import DeepRacerEnv
from racer.shared.sim.scene._mujoco import mujoco
from racer.shared.sim.sensors.camera import CENTER_CAMERA, FULL_HEIGHT_PX, FULL_WIDTH_PX, CameraRenderer


def _raw_block(
    env: DeepRacerEnv, data: mujoco.MjData, renderer: CameraRenderer, starts: list, commands: np.ndarray
) -> tuple[float, float]:
    """Physics + render only, with pre-drawn random commands. Like the env's random-policy car, the car restarts
    (round-robin poses) when its origin leaves the road, so the camera sees comparable views."""
    model, car, substeps, track = env.model, env.car, env.config.physics_substeps, env.track
    body = car.body_id
    restarts = 0
    car.teleport(model, data, *starts[0])
    start, cpu_start = time.perf_counter(), time.process_time()
    for speed_mps, steering_deg in commands:
        x, y = data.xpos[body, 0], data.xpos[body, 1]
        if not track.contains(x, y):
            restarts += 1
            car.teleport(model, data, *starts[restarts % len(starts)])
        car.command(data, speed_mps, steering_deg)
        car.step(model, data, substeps)
        renderer.start(data, CENTER_CAMERA)
        renderer.finish()
    return time.perf_counter() - start, time.process_time() - cpu_start


def run_benchmark(
    steps: int = 3000, blocks: int = 6, seed: int = 0, full_resolution: bool = False, track: str = DEFAULT_TRACK
) -> dict[str, float | str]:
    with tempfile.TemporaryDirectory() as folder:
        reward_path = Path(folder) / "reward.py"
        reward_path.write_text(BENCH_REWARD)
        env = DeepRacerEnv(
            EnvConfig(track=track, reward_function_path=reward_path, render_full_resolution=full_resolution)
        )
        try:
            env.reset(seed=seed)
            rng = np.random.default_rng(seed)
            raw_data = mujoco.MjData(env.model)
            size = (
                (FULL_HEIGHT_PX, FULL_WIDTH_PX)
                if full_resolution
                else (env.config.image_height_px, env.config.image_width_px)
            )
            renderer = CameraRenderer(env.model, width_px=size[1], height_px=size[0])
            starts = [env.track.pose_at(i / 20.0) for i in range(20)]
            actions = env.config.model_metadata.discrete_actions
            per_block = max(steps // blocks, 1)
            picks = rng.integers(len(actions), size=per_block)
            commands = np.array([(actions[i].speed_mps, actions[i].steering_angle_deg) for i in picks])
            env_block(env, rng, 30)
            _raw_block(env, raw_data, renderer, starts, commands[:30])
            env_s = raw_s = env_cpu_s = raw_cpu_s = 0.0
            for _ in range(blocks):
                wall_s, cpu_s = env_block(env, rng, per_block)
                env_s, env_cpu_s = env_s + wall_s, env_cpu_s + cpu_s
                wall_s, cpu_s = _raw_block(env, raw_data, renderer, starts, commands)
                raw_s, raw_cpu_s = raw_s + wall_s, raw_cpu_s + cpu_s
            renderer.close()
        finally:
            env.close()
    total = per_block * blocks
    env_rate = total / env_s
    raw_rate = total / raw_s
    return {
        "env_steps_per_s": round(env_rate, 1),
        "raw_bound_steps_per_s": round(raw_rate, 1),
        "ratio": round(env_rate / raw_rate, 3),
        # Process CPU time (includes llvmpipe's render threads): comparable across runs on a busy machine.
        "env_cpu_ms_per_step": round(1e3 * env_cpu_s / total, 3),
        "raw_cpu_ms_per_step": round(1e3 * raw_cpu_s / total, 3),
        "steps": total,
        "track": str(track),
    }


def raw_rate_child(start_at_epoch_s: float, duration_s: float, seed: int = 0) -> None:
    """One process of `python -m benchmarks throughput`'s machine bound: `run_benchmark`'s raw loop (physics + camera, no env
    code, no policy) from `start_at_epoch_s` for `duration_s`, so that one such process per core runs at the same
    time; prints one JSON line with its steps/s."""
    env = DeepRacerEnv(EnvConfig())
    try:
        env.reset(seed=seed)
        rng = np.random.default_rng(seed)
        data = mujoco.MjData(env.model)
        renderer = CameraRenderer(env.model, width_px=env.config.image_width_px, height_px=env.config.image_height_px)
        starts = [env.track.pose_at(i / 20.0) for i in range(20)]
        actions = env.config.model_metadata.discrete_actions
        picks = rng.integers(len(actions), size=100)
        commands = np.array([(actions[i].speed_mps, actions[i].steering_angle_deg) for i in picks])
        _raw_block(env, data, renderer, starts, commands[:30])
        time.sleep(max(0.0, start_at_epoch_s - time.time()))
        steps, wall_s, cpu_s = 0, 0.0, 0.0
        while wall_s < duration_s:
            block_wall_s, block_cpu_s = _raw_block(env, data, renderer, starts, commands)
            steps, wall_s, cpu_s = steps + len(commands), wall_s + block_wall_s, cpu_s + block_cpu_s
        renderer.close()
    finally:
        env.close()
    print(json.dumps({"steps_per_s": steps / wall_s, "cpu_ms_per_step": 1e3 * cpu_s / steps}), flush=True)


@click.command("sim")
@click.option("--steps", default=3000, show_default=True, help="Steps measured for each of env and raw bound.")
@click.option("--seed", default=0, show_default=True)
@click.option(
    "--track",
    default=DEFAULT_TRACK,
    show_default=True,
    help="Track for the time-trial figure: a route name (any SimApp track, fetched on first use), a DeepRacer-on-AWS "
    "name or a .npy path.",
)
@direction_option
@click.option(
    "--full-resolution", is_flag=True, help="Render 640x480 and resize, as DeepRacer (default: 160x120 directly)."
)
@click.option(
    "--obstacles",
    default=0,
    show_default=True,
    type=click.IntRange(min=0),
    help="Also measure an OBJECT_AVOIDANCE env with this many boxes, beside the time trial.",
)
@click.option(
    "--bot-cars",
    default=0,
    show_default=True,
    type=click.IntRange(min=0),
    help="Also measure a HEAD_TO_BOT env with this many bot cars (0.5 m/s, changing lanes), beside the time trial.",
)
def sim_bench_command(steps: int, seed: int, track: str, full_resolution: bool, obstacles: int, bot_cars: int) -> None:
    """Measure simulator throughput; prints one JSON line."""
    if obstacles or bot_cars:
        if full_resolution:
            raise click.UsageError("--full-resolution measures the time trial against the raw bound only")
        if track != DEFAULT_TRACK:
            raise click.UsageError("--track applies to the time-trial figure; the object figures use the default track")
        click.echo(json.dumps(run_race_type_benchmark(obstacles, bot_cars, steps=steps, seed=seed)))
        return
    click.echo(json.dumps(run_benchmark(steps=steps, seed=seed, full_resolution=full_resolution, track=track)))
