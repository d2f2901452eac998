"""Frame pairs: each Gazebo frame beside racer's frame at the same pose; do policies read them alike?

The 92 Gazebo frames (`frames/gazebo_reinvent_episode`) carry no pose, but their painted lines do: `fit.py` finds
each frame's pose on re:Invent 2018 from them. racer renders its own frame there. Every policy (the real
checkpoints, and a racer model if given) then picks its greedy steering side on both frames of each pair. A pair
counts when the two frames' line masks overlap (IoU >= 0.5; the track repeats itself, so a fit may land on a twin of
the right place, which is as good for this purpose when the views match). A policy that reads racer's frames as it
reads Gazebo's picks the same side on both.

The control: the same policy on racer's frame and on racer's frame with the pose moved by a fit's size of error
(2 cm, 2 degrees, random): how often that alone flips the side. A pair agreement at that level is all a look change
could still explain.

The fit also says which camera took the frames: the projected lines fit best at the mount the projection assumes,
so `--camera-height` / `--camera-forward` try another (the older (0.2, 0, 0.164) m mount of SimApp version < 3).
"""

from __future__ import annotations

import json
import math
import os
import sys
import tempfile
import time
from pathlib import Path

import click
import cv2
import numpy as np

from benchmarks.gazebo_frames import GAZEBO_FRAMES, load_gazebo_frames, render_poses
from benchmarks.workdir import cpu_description
from research import data_option
from research.camera_proxies.grey_stats import paired_grey_stats
from research.frame_pairs.fit import CameraMount, fit_poses, line_masks
from research.frame_pairs.poses import FITTED_POSES

ROUTE = "routes/reinvent_base.npy"

GOOD_PAIR_IOU = 0.5
POSE_NOISE = (0.02, math.radians(2.0))
"""The control's pose error: metres in x and y, radians of heading (standard deviations)."""


def line_iou(first: np.ndarray, second: np.ndarray) -> float:
    """Overlap of two RGB frames' line masks (yellow with yellow, white with white; dilated by 2 pixels)."""
    kernel = np.ones((5, 5), np.uint8)
    masks = [[cv2.dilate(m.astype(np.uint8), kernel) > 0 for m in line_masks(frame)] for frame in (first, second)]
    both = sum(int((a & b).sum()) for a, b in zip(*masks, strict=True))
    either = sum(int((a | b).sum()) for a, b in zip(*masks, strict=True))
    return both / either if either else 0.0


def render_at(route: Path, poses: list[tuple[float, float, float]]) -> np.ndarray:
    """racer's RGB camera frames at the car poses (x, y, yaw): base world, the default render, racer's camera."""
    return render_poses(route, "base", poses, full_resolution=False)[0]


def grey_of(frames_rgb: np.ndarray) -> np.ndarray:
    from racer.shared.sim.sensors.camera import rgb_to_y

    return np.stack([rgb_to_y(frame) for frame in frames_rgb])


def side_agreement(first: np.ndarray, second: np.ndarray, where: np.ndarray | None = None) -> float:
    if where is not None:
        first, second = first[where], second[where]
    return round(float(np.mean(first == second)), 3) if len(first) else float("nan")


def pairs_picture(gazebo: np.ndarray, ours: np.ndarray, iou: np.ndarray, path: Path, columns: int = 4) -> None:
    """Each Gazebo frame with racer's frame at its fitted pose to the right; the pair's line IoU on top."""
    tiles = []
    for left, right, overlap in zip(gazebo, ours, iou, strict=True):
        tile = np.hstack([left, right, np.full((left.shape[0], 4, 3), 255, np.uint8)])
        colour = (40, 220, 40) if overlap >= GOOD_PAIR_IOU else (240, 60, 60)
        cv2.putText(tile, f"IoU {overlap:.2f}", (4, 12), cv2.FONT_HERSHEY_SIMPLEX, 0.4, colour, 1, cv2.LINE_AA)
        tiles.append(tile)
    while len(tiles) % columns:
        tiles.append(np.zeros_like(tiles[0]))
    grid = np.vstack([np.hstack(tiles[i : i + columns]) for i in range(0, len(tiles), columns)])
    path.parent.mkdir(parents=True, exist_ok=True)
    cv2.imwrite(str(path), cv2.cvtColor(grid, cv2.COLOR_RGB2BGR))


def compare_policies(
    gazebo: np.ndarray, ours: np.ndarray, jittered: np.ndarray, good: np.ndarray, real: dict, racer: dict
) -> dict:
    """Per policy ({label: (metadata, network)}): steering-side agreement between the two frames of each pair (all,
    and the good pairs), the control (racer's frame against racer's frame at a jittered pose) and the shares; for a
    racer policy also its agreement with each real one, on the Gazebo frames and on racer's frames of the same poses."""
    from benchmarks.transfer_reverse_check import side_fractions, steering_sides

    grey = {"gazebo": grey_of(gazebo), "racer": grey_of(ours), "jittered": grey_of(jittered)}
    sides = {
        label: {name: steering_sides(metadata, network, frames) for name, frames in grey.items()}
        for label, (metadata, network) in {**real, **racer}.items()
    }
    result = {}
    for label, own in sides.items():
        figures = {
            "pairs_all": side_agreement(own["gazebo"], own["racer"]),
            "pairs_good": side_agreement(own["gazebo"], own["racer"], good),
            "control_pose_noise": side_agreement(own["racer"], own["jittered"]),
            "shares_gazebo": side_fractions(own["gazebo"]),
            "shares_racer": side_fractions(own["racer"]),
        }
        if label in racer:
            figures["agreement_with_real"] = {
                other: {
                    "gazebo_frames": side_agreement(own["gazebo"], sides[other]["gazebo"]),
                    "racer_frames_same_poses": side_agreement(own["racer"], sides[other]["racer"]),
                }
                for other in real
            }
        result[label] = figures
    return result


def run_frame_pairs(
    data: Path, camera: CameraMount, jobs: int, limit: int | None, racer_model: Path | None, picture: Path | None
) -> dict:
    from benchmarks.real_models import import_real_models, model_folders

    started = time.perf_counter()
    route_path = data / ROUTE
    frames = load_gazebo_frames(data / GAZEBO_FRAMES)[:limit]
    route = np.load(route_path)
    print(f"frame-pairs: fitting {len(frames)} frames' poses ({jobs} processes)", file=sys.stderr, flush=True)
    fitted = fit_poses(frames, route, camera, jobs)
    poses = [(p.x_m, p.y_m, p.yaw_rad) for p in fitted]
    ours = render_at(route_path, poses)
    rng = np.random.default_rng(0)
    jittered_poses = [
        (x + rng.normal(0, POSE_NOISE[0]), y + rng.normal(0, POSE_NOISE[0]), yaw + rng.normal(0, POSE_NOISE[1]))
        for x, y, yaw in poses
    ]
    jittered = render_at(route_path, jittered_poses)
    iou = np.array([line_iou(g, o) for g, o in zip(frames, ours, strict=True)])
    good = iou >= GOOD_PAIR_IOU
    with tempfile.TemporaryDirectory(prefix="racer-frame-pairs-") as store_root:
        real = {
            model.label: (model.metadata, model.network)
            for model in import_real_models(model_folders(data / "models"), Path(store_root))
        }
    racer = racer_policies(racer_model) if racer_model is not None else {}
    by_policy = compare_policies(frames, ours, jittered, good, real, racer)
    if picture is not None:
        pairs_picture(frames, ours, iou, picture)
    return {
        "study": "frame-pairs",
        "cpu": cpu_description(),
        "frames": len(frames),
        "camera": camera.__dict__,
        "fit_cost_cm": {"median": round(float(np.median([p.cost_m for p in fitted])) * 100, 2)},
        "line_iou": {"median": round(float(np.median(iou)), 3), "good_pairs": int(good.sum())},
        "grey": paired_grey_stats(grey_of(ours), grey_of(frames)),
        "policies": by_policy,
        "poses": [{"x_m": round(x, 4), "y_m": round(y, 4), "yaw_rad": round(yaw, 4)} for x, y, yaw in poses],
        "picture": str(picture) if picture is not None else None,
        "wall_s": round(time.perf_counter() - started, 1),
    }


def racer_policies(model_folder: Path) -> dict[str, tuple]:
    """The last four checkpoints of a racer model folder (racer's local store layout)."""
    from benchmarks.transfer_reverse_check import open_racer_model

    metadata, checkpoints = open_racer_model(model_folder)
    return {f"racer:{name}": (metadata, checkpoints.load_policy(name)) for name in checkpoints.names()[-4:]}


@click.command(name="frame-pairs")
@data_option("Gazebo frames, re:Invent 2018 route, models/")
@click.option(
    "--racer-model",
    type=click.Path(exists=True, file_okay=False, path_type=Path),
    default=None,
    help="A racer model folder (racer-data/MODEL): its last four checkpoints are compared too.",
)
@click.option(
    "--picture", type=click.Path(dir_okay=False, path_type=Path), default=None, help="Write the pairs as a PNG."
)
@click.option(
    "--save-poses",
    type=click.Path(dir_okay=False, path_type=Path),
    default=None,
    help=f"Write the fitted poses as JSON ({FITTED_POSES.name} beside this study is this file, read by "
    "research/camera_proxies).",
)
@click.option("--frames", "limit", type=click.IntRange(1, None), default=None, help="Only the first N frames.")
@click.option("--jobs", type=click.IntRange(1, None), default=None, help="Processes fitting poses. Default: the cores.")
@click.option(
    "--camera-height",
    type=float,
    default=CameraMount.height_m,
    show_default=True,
    help="Metres; the camera the fit assumes took the Gazebo frames (racer renders with its own).",
)
@click.option(
    "--camera-forward", type=float, default=CameraMount.forward_m, show_default=True, help="Metres, as above."
)
def frame_pairs_command(
    data: Path,
    racer_model: Path | None,
    picture: Path | None,
    save_poses: Path | None,
    limit: int | None,
    jobs: int | None,
    camera_height: float,
    camera_forward: float,
) -> None:
    """Fit each Gazebo frame's pose from its lines, render racer's frame there, and compare policies on the pairs."""
    from racer.shared.sim.scene.gl import ensure_gl_backend

    ensure_gl_backend()
    camera = CameraMount(forward_m=camera_forward, height_m=camera_height)
    result = run_frame_pairs(data, camera, jobs or os.cpu_count() or 1, limit, racer_model, picture)
    if save_poses is not None:
        document = {
            "about": "Car poses of the Gazebo frames (frames/gazebo_reinvent_episode, in file order) "
            "on re:Invent 2018, "
            "fitted from their painted lines by `python -m research.frame_pairs`",
            "camera": result["camera"],
            "fit_cost_cm_median": result["fit_cost_cm"]["median"],
            "poses": result["poses"],
        }
        save_poses.write_text(json.dumps(document, indent=1) + "\n")
    click.echo(json.dumps(result))
