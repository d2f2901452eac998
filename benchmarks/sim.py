"""`python -m benchmarks sim`: environment steps per second against the raw MuJoCo bound, measured in the same run.

What is measured is in `sim_measure.py`; this module imports no MuJoCo, so `--renderer` is applied before `mujoco`
loads. The JSON names the renderer (`renderer`, `mujoco_gl`, `gl_renderer`); when the frames came from a GPU, the
same measurement with the CPU renderer runs in a child process and lands under `cpu_renderer`, so both figures come
from one machine in one invocation.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import click

from racer.options.renderer import renderer_option
from racer.options.track import direction_option, track_option
from racer.options.training import seed_option
from racer.shared.sim.config import DEFAULT_TRACK
from racer.shared.sim.scene.gl import ensure_gl_backend
from racer.shared.sim.scene.renderer import (
    RendererError,
    apply_renderer,
    choose_renderer,
    gl_renderer_name,
    is_software_renderer,
)

CPU_RENDERER_TIMEOUT_S = 1800.0


def _apply(renderer: str) -> dict[str, str]:
    try:
        choice = choose_renderer(renderer)
    except RendererError as error:
        raise click.UsageError(str(error)) from error
    apply_renderer(choice)
    ensure_gl_backend()  # auto: egl, else osmesa, as every racer process chooses
    return {
        "renderer": renderer + (" (MUJOCO_GL overrides it)" if choice.overridden else ""),
        "mujoco_gl": os.environ.get("MUJOCO_GL", ""),
        "gl_renderer": gl_renderer_name(),
    }


def _cpu_renderer_figures(steps: int, seed: int, full_resolution: bool, track: str) -> dict:
    """The same benchmark with `--renderer cpu`, in a child process (a process renders with one GL vendor)."""
    env = {
        key: value for key, value in os.environ.items() if key not in ("MUJOCO_GL", "__EGL_VENDOR_LIBRARY_FILENAMES")
    }
    command = [sys.executable, "-m", "benchmarks", "sim", "--renderer", "cpu", "--steps", str(steps)]
    command += ["--seed", str(seed), "--track", track] + (["--full-resolution"] if full_resolution else [])
    result = subprocess.run(command, env=env, capture_output=True, text=True, timeout=CPU_RENDERER_TIMEOUT_S)
    if result.returncode != 0:
        raise click.ClickException(f"the CPU renderer's run failed: {result.stderr.strip()[-2000:]}")
    return json.loads(result.stdout.strip().splitlines()[-1])


@click.command("sim")
@click.option("--steps", default=3000, show_default=True, help="Steps measured for each of env and raw bound.")
@seed_option
@track_option()
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
@renderer_option
def sim_bench_command(
    steps: int, seed: int, track: str, full_resolution: bool, obstacles: int, bot_cars: int, renderer: str
) -> None:
    """Measure simulator throughput; prints one JSON line."""
    rendering = _apply(renderer)
    from benchmarks.sim_measure import run_benchmark
    from benchmarks.sim_race_types import run_race_type_benchmark

    if obstacles or bot_cars:
        if full_resolution:
            raise click.UsageError("--full-resolution measures the time trial against the raw bound only")
        if track != DEFAULT_TRACK:
            raise click.UsageError("--track applies to the time-trial figure; the object figures use the default track")
        click.echo(json.dumps({**run_race_type_benchmark(obstacles, bot_cars, steps=steps, seed=seed), **rendering}))
        return
    result = {**run_benchmark(steps=steps, seed=seed, full_resolution=full_resolution, track=track), **rendering}
    if not is_software_renderer(rendering["gl_renderer"]):
        result["cpu_renderer"] = _cpu_renderer_figures(steps, seed, full_resolution, track)
    click.echo(json.dumps(result))
