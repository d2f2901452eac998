"""The camera proxy: how close racer's camera frames are to DeepRacer's, and what each render path costs.

For each world, racer renders the front camera at poses spread evenly around the re:Invent 2018 lap (centre line,
heading along the route) and compares them with the real in-car frames of one Gazebo episode
(`frames/gazebo_reinvent_episode`, 160x120 RGB): the earth-mover distance between the grayscale histograms (in grey
levels; RL Coach's grayscale), the mean grey of the lower half (mostly road) and of the upper third (walls and what is
above them). Those poses are not the episode's, so the same figures are also taken on the pairs (`paired`): racer's
frames at the Gazebo frames' own poses (research/frame_pairs/gazebo_frame_poses.json), where the views match and
only the look differs. The direct 160x120 frame is compared with racer's 640x480 + bilinear-resize path at the same
poses (mean absolute grey difference), and both paths are timed. With `--checkpoint`, a racer policy's greedy left /
straight / right shares on the Gazebo frames show how it reads DeepRacer's images.
"""

from __future__ import annotations

import json
import time
from pathlib import Path

import click
import numpy as np

from benchmarks.gazebo_frames import GAZEBO_FRAMES, load_gazebo_frames, render_lap, render_poses
from racer.shared.sim.config import EnvConfig
from racer.shared.sim.env import DeepRacerEnv
from racer.shared.sim.scene.worlds import WORLD_NAMES
from racer.shared.sim.sensors.camera import CENTER_CAMERA, CameraRenderer, rgb_to_y
from research import DEEPRACER_DATA, data_option
from research.camera_proxies.grey_stats import frame_stats, histogram_emd, paired_grey_stats
from research.frame_pairs.poses import load_fitted_poses

ROUTE = "routes/reinvent_base.npy"


def frame_cost_ms(
    route: Path, world: str, full_resolution: bool, frames: int = 300, simapp_dir: Path | None = None
) -> float:
    """Mean milliseconds per frame over `frames` renders while driving slowly around the lap (after a warm-up)."""
    env = DeepRacerEnv(
        EnvConfig(track=route, world=world, render_full_resolution=full_resolution, simapp_dir=simapp_dir)
    )
    try:
        env.reset(seed=0)
        renderer: CameraRenderer = env._camera
        poses = [env.track.pose_at(float(i) / frames, "center") for i in range(frames)]
        for pose in poses[:20]:
            env.teleport(*pose)
            renderer.start(env.data, CENTER_CAMERA)
            renderer.finish()
        start = time.perf_counter()
        for pose in poses:
            env.teleport(*pose)
            renderer.start(env.data, CENTER_CAMERA)
            renderer.finish()
        return 1e3 * (time.perf_counter() - start) / frames
    finally:
        env.close()


def policy_shares(model_dir: Path, frames_rgb: np.ndarray) -> dict[str, float]:
    """Greedy left / straight / right shares of a racer model's newest checkpoint on the frames.

    `model_dir` is a model folder in racer's local store layout (`<store>/<model>/model/...`); positive steering is
    left, as in DeepRacer. A continuous policy counts |steering| below 1 degree as straight.
    """
    import torch

    from racer.shared.config import LocalStoreSettings
    from racer.shared.deepracer.model_metadata import parse_model_metadata
    from racer.shared.policy.checkpoints import CheckpointStore
    from racer.shared.store import open_store

    metadata_path = model_dir / "model" / "model_metadata.json"
    if not metadata_path.is_file():
        raise click.ClickException(f"{metadata_path} is missing: --checkpoint takes a racer model folder")
    metadata = parse_model_metadata(json.loads(metadata_path.read_text()), source=str(metadata_path))
    torch.set_num_threads(1)
    network = CheckpointStore(open_store(LocalStoreSettings(root=model_dir.parent)), model_dir.name).load_policy()
    counts = {"left": 0, "straight": 0, "right": 0}
    for frame in frames_rgb:
        action, _ = network.act({metadata.camera_sensor: rgb_to_y(frame)[:, :, None]}, greedy=True)
        if metadata.is_continuous:
            steering = float(metadata.scale_continuous_action(np.asarray(action, dtype=np.float64))[0])
            side = "straight" if abs(steering) < 1.0 else ("left" if steering > 0 else "right")
        else:
            steering = metadata.discrete_actions[int(action)].steering_angle_deg
            side = "straight" if steering == 0 else ("left" if steering > 0 else "right")
        counts[side] += 1
    return {side: round(count / len(frames_rgb), 3) for side, count in counts.items()}


def paired_stats(
    gazebo_gray: np.ndarray, route: Path, world: str, poses: list[tuple[float, float, float]], simapp: Path | None
) -> dict:
    """racer's frames at the Gazebo frames' own poses against those frames."""
    ours_rgb, _ = render_poses(route, world, poses, full_resolution=False, simapp_dir=simapp)
    return paired_grey_stats(np.stack([rgb_to_y(frame) for frame in ours_rgb]), gazebo_gray)


def run_camera_proxy(
    data_dir: Path = DEEPRACER_DATA,
    poses: int = 40,
    worlds: tuple[str, ...] = WORLD_NAMES,
    checkpoint: Path | None = None,
    simapp_dir: Path | None = None,
) -> dict:
    """The report; with `simapp_dir`, each world is measured a second time drawn from DeepRacer's own meshes
    (key `<world>+simapp`)."""
    route = data_dir / ROUTE
    if not route.is_file():
        raise click.ClickException(f"route file missing: {route}; pass --data DIR (the DeepRacer test data)")
    gazebo_rgb = load_gazebo_frames(data_dir / GAZEBO_FRAMES)
    gazebo = frame_stats(np.stack([rgb_to_y(frame) for frame in gazebo_rgb]))
    half = len(gazebo_rgb) // 2
    first = frame_stats(np.stack([rgb_to_y(frame) for frame in gazebo_rgb[:half]]))
    second = frame_stats(np.stack([rgb_to_y(frame) for frame in gazebo_rgb[half:]]))
    result: dict = {
        "gazebo_frames": len(gazebo_rgb),
        "gazebo_lower_half_mean": round(gazebo.lower_half_mean, 1),
        "gazebo_upper_third_mean": round(gazebo.upper_third_mean, 1),
        "gazebo_halves_emd": round(histogram_emd(first.histogram, second.histogram), 2),
        "poses": poses,
        "worlds": {},
    }
    fitted_poses = load_fitted_poses()
    gazebo_gray = np.stack([rgb_to_y(frame) for frame in gazebo_rgb])
    runs = [(world, None) for world in worlds]
    if simapp_dir is not None:
        runs += [(world, simapp_dir) for world in worlds]
    for world, simapp in runs:
        direct_rgb, _ = render_lap(route, world, poses, full_resolution=False, simapp_dir=simapp)
        full_rgb, _ = render_lap(route, world, poses, full_resolution=True, simapp_dir=simapp)
        direct_gray = np.stack([rgb_to_y(frame) for frame in direct_rgb])
        full_gray = np.stack([rgb_to_y(frame) for frame in full_rgb])
        stats = frame_stats(direct_gray)
        direct_ms = frame_cost_ms(route, world, full_resolution=False, simapp_dir=simapp)
        full_ms = frame_cost_ms(route, world, full_resolution=True, simapp_dir=simapp)
        result["worlds"][world if simapp is None else f"{world}+simapp"] = {
            "histogram_emd": round(histogram_emd(stats.histogram, gazebo.histogram), 2),
            "lower_half_mean": round(stats.lower_half_mean, 1),
            "upper_third_mean": round(stats.upper_third_mean, 1),
            "default_vs_full_resolution_mad": round(float(np.abs(direct_gray.astype(int) - full_gray).mean()), 3),
            "default_frame_ms": round(direct_ms, 3),
            "full_resolution_frame_ms": round(full_ms, 3),
            "paired": paired_stats(gazebo_gray, route, world, fitted_poses, simapp),
        }
    if checkpoint is not None:
        result["policy_shares_on_gazebo_frames"] = policy_shares(checkpoint, gazebo_rgb)
    return result


@click.command("camera")
@data_option("the re:Invent 2018 route and the Gazebo frames")
@click.option("--poses", default=40, show_default=True, help="Poses around the re:Invent 2018 lap.")
@click.option("--worlds", default=",".join(WORLD_NAMES), show_default=True, help="Comma-separated worlds.")
@click.option(
    "--checkpoint",
    type=click.Path(exists=True, file_okay=False, path_type=Path),
    default=None,
    help="A racer model folder (e.g. racer-data/MODEL): its newest checkpoint's steering shares.",
)
@click.option(
    "--simapp",
    "simapp_dir",
    type=click.Path(exists=True, file_okay=False, path_type=Path),
    default=None,
    help="Also measure each world drawn from DeepRacer's own meshes in this SimApp bundle/ folder.",
)
def camera_command(data: Path, poses: int, worlds: str, checkpoint: Path | None, simapp_dir: Path | None) -> None:
    """Compare racer's camera frames with DeepRacer's Gazebo frames; prints one JSON line."""
    names = tuple(name.strip() for name in worlds.split(",") if name.strip())
    unknown = [name for name in names if name not in WORLD_NAMES]
    if unknown:
        raise click.BadParameter(
            f"unknown world(s) {unknown}; choose from {', '.join(WORLD_NAMES)}", param_hint="--worlds"
        )
    click.echo(json.dumps(run_camera_proxy(data, poses, names, checkpoint, simapp_dir)))
