"""`python -m benchmarks race-pace --picture`: the bound's racing line coloured by its speed, and the policy's best lap beside it
on the same colours, the line drawn under it. The best lap is driven again from its checkpoint, as worker 0 drove it
(its settings from the store, its continuous run from the start line): racer's simulator is deterministic, so the
replay is the same lap, and the bench says whether it matches the evaluation's. The trainer keeps only the newest
checkpoints, so the bench copies the one to draw aside as soon as its evaluation arrives (`keep_checkpoint`)."""

from __future__ import annotations

import threading
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from matplotlib.colors import Normalize
from matplotlib.figure import Figure

from racer.racing_line import RacingLine
from racer.racing_line.picture import draw_road, speed_segments
from racer.rollout_worker.checkpoint_evaluation import evaluation_epsilon, play_consecutive_laps
from racer.rollout_worker.worker_files import load_worker_files, training_env_config
from racer.shared.model_layout import CheckpointName, ModelLayout
from racer.shared.policy.checkpoints import CheckpointStore
from racer.shared.sim.config import STEPS_PER_SECOND
from racer.shared.sim.env import DeepRacerEnv
from racer.shared.sim.tracks.track import Track
from racer.shared.store import ObjectStore

DPI = 110
SPEED_SMOOTHING_STEPS = 5
"""A 1/3 s centred mean: one 15 Hz step's displacement is too noisy to read as a speed."""


@dataclass(frozen=True)
class DrivenLap:
    """One lap of a checkpoint's evaluation run, driven again."""

    checkpoint: str
    lap_index: int
    points_m: np.ndarray
    """(steps, 2) the car's position at each step (the simtrace's X, Y)."""
    lap_time_s: float | None
    progress: float
    """Progress (%) when the lap ended: 100 for a completed one."""
    simtrace_rows: tuple[dict, ...] = ()
    """The lap's DeepRacer simtrace rows, one per step (benchmarks.race_pace_losses reads them)."""

    @property
    def speeds_mps(self) -> np.ndarray:
        """Per segment between steps: the distance over one step's time, smoothed."""
        steps = np.linalg.norm(np.diff(self.points_m, axis=0), axis=1) * STEPS_PER_SECOND
        kernel = np.ones(SPEED_SMOOTHING_STEPS) / SPEED_SMOOTHING_STEPS
        padded = np.pad(steps, SPEED_SMOOTHING_STEPS // 2, mode="edge")
        return np.convolve(padded, kernel, mode="valid")


def keep_checkpoint(run_store: ObjectStore, kept: ObjectStore, model_prefix: str, checkpoint: str) -> None:
    """Copy what acting with `checkpoint` needs (its files and its ONNX model) from the run's store to `kept`, under
    the same keys, before the trainer's retention deletes it."""
    layout = ModelLayout(model_prefix)
    number = CheckpointName.parse(checkpoint).number
    wanted = layout.inference_model(number)
    for key in run_store.list_keys(layout.model_dir):
        if key == wanted or key.rsplit("/", 1)[-1].startswith(checkpoint + "."):
            kept.put_bytes(key, run_store.get_bytes(key))


def drive_lap_again(
    run_store: ObjectStore,
    checkpoints: ObjectStore,
    model_prefix: str,
    checkpoint: str,
    lap_index: int,
    workdir: Path,
    seed: int,
) -> DrivenLap:
    """Lap `lap_index` of `checkpoint`'s continuous evaluation run, driven again with worker 0's env and settings (from
    `run_store`) and the checkpoint (from `checkpoints`, where `keep_checkpoint` put it)."""
    run = load_worker_files(run_store, model_prefix, 0, workdir)
    policy = CheckpointStore(checkpoints, model_prefix).load_inference_policy(checkpoint)
    policy.eval()
    env = DeepRacerEnv(training_env_config(run))
    try:
        env.reset(seed=seed)  # worker 0's first env gets the run's seed
        laps = play_consecutive_laps(
            env,
            policy,
            laps=run.worker.min_eval_trials,
            generator=np.random.default_rng(seed),
            epsilon=evaluation_epsilon(run.hyperparameters, run.model_metadata),
            policy_version=0,
            worker_id=0,
            world=run.worker.world,
            on_step=lambda *step: None,
            stop=threading.Event(),
            max_steps=run.worker.eval_max_steps or None,
        )
    finally:
        env.close()
    if laps is None or lap_index >= len(laps):
        raise RuntimeError(
            f"driving {checkpoint} again gave {0 if laps is None else len(laps)} laps, not lap {lap_index}"
        )
    lap = laps[lap_index]
    points = np.array([(row["X"], row["Y"]) for row in lap.simtrace_rows], dtype=float)
    return DrivenLap(checkpoint, lap_index, points, lap.lap_time_s, lap.progress, lap.simtrace_rows)


def draw_pace(track: Track, line: RacingLine, lap: DrivenLap | None, title: str, path: Path) -> Path:
    """Two maps on one speed scale: the bound's line, and the policy's lap over the line (thin)."""
    panels = 2 if lap is not None else 1
    figure = Figure(figsize=(6.5 * panels, 5.2), layout="constrained")
    axes = np.atleast_1d(figure.subplots(1, panels))
    top = max(float(line.speeds_mps.max()), float(lap.speeds_mps.max()) if lap is not None else 0.0)
    norm = Normalize(0.0, top)
    closed = np.vstack((line.points_m, line.points_m[:1]))
    line_speeds = np.append(line.speeds_mps, line.speeds_mps[:1])
    collection = speed_segments(closed, 0.5 * (line_speeds[:-1] + line_speeds[1:]), norm, width=3.0)
    draw_road(axes[0], track)
    axes[0].add_collection(collection)
    axes[0].set_title(f"bound: {line.lap_time_s:.2f} s flying lap, {line.standing_average_s:.2f} s over 3 from rest")
    if lap is not None:
        draw_road(axes[1], track)
        axes[1].plot(*closed.T, color="0.45", linewidth=0.8, linestyle="--", zorder=2)
        axes[1].add_collection(speed_segments(lap.points_m, lap.speeds_mps, norm, width=2.5))
        axes[1].plot(*lap.points_m[0], "o", color="green", markersize=5, zorder=4)
        lap_text = f"{lap.progress:.0f} %, no lap yet" if lap.lap_time_s is None else f"{lap.lap_time_s:.2f} s"
        axes[1].set_title(f"policy: {lap.checkpoint}, lap {lap.lap_index + 1}: {lap_text}")
    figure.colorbar(collection, ax=axes.tolist(), label="speed (m/s)", shrink=0.8)
    figure.suptitle(title)
    figure.savefig(path, dpi=DPI, bbox_inches="tight")
    return path
