"""research/frame_pairs fits a frame's pose from its painted lines, renders racer's frame there and compares
policies on the pairs. The fit is checked on racer's own frames (the pose is known) and on a real Gazebo frame."""

from __future__ import annotations

import json

import numpy as np
import pytest
from click.testing import CliRunner
from PIL import Image

from research.frame_pairs.fit import CameraMount, RouteLines, fit_pose, ground_points, line_masks
from research.frame_pairs.pairs import frame_pairs_command, line_iou, render_at
from tests.shared_data import SHARED_DATA

ROUTE = SHARED_DATA / "routes" / "reinvent_base.npy"
GAZEBO_FRAME = SHARED_DATA / "frames" / "gazebo_reinvent_episode" / "sim-image-3-00160.png"


def test_a_straight_line_ahead_projects_to_the_ground_ahead():
    mask = np.zeros((120, 160), bool)
    mask[80:120, 79:81] = True  # the image's middle columns, below the horizon
    points = ground_points(mask, CameraMount())
    assert len(points) > 0
    assert np.all(points[:, 0] > CameraMount().forward_m)  # in front of the camera
    assert np.all(np.abs(points[:, 1]) < 0.02)  # and straight ahead of it


@pytest.mark.slow
def test_racer_frames_at_known_poses_fit_back_to_the_same_view():
    lines = RouteLines(np.load(ROUTE))
    known = [tuple(p) for p in lines.poses(np.array([1.0, 9.0]), np.array([0.1]), np.radians([8.0]))]
    frames = render_at(ROUTE, known)
    fitted = [fit_pose(frame, lines) for frame in frames]
    refits = render_at(ROUTE, [(p.x_m, p.y_m, p.yaw_rad) for p in fitted])
    for frame, refit, pose in zip(frames, refits, fitted, strict=True):
        # the track repeats itself, so the fit may pick a twin of the place: the views must match, not the numbers
        assert line_iou(frame, refit) > 0.6
        assert pose.cost_m < 0.02
    # the true pose fits about as well as the one found (the score is about the geometry, not luck)
    yellow, white = (ground_points(m, CameraMount()) for m in line_masks(frames[0]))
    assert lines.fit_cost(np.array([known[0]]), yellow, white)[0] < fitted[0].cost_m + 0.005


@pytest.mark.slow
def test_a_gazebo_frame_fits_better_with_the_current_camera_mount_than_the_old_one():
    frame = np.asarray(Image.open(GAZEBO_FRAME).convert("RGB"))
    lines = RouteLines(np.load(ROUTE))
    current = fit_pose(frame, lines)
    older = fit_pose(frame, lines, CameraMount(forward_m=0.2, height_m=0.164))
    assert current.cost_m < older.cost_m
    ours = render_at(ROUTE, [(current.x_m, current.y_m, current.yaw_rad)])[0]
    assert line_iou(frame, ours) > 0.5


@pytest.mark.slow
def test_the_stored_poses_are_the_fit_of_their_frames():
    """The camera proxy renders at gazebo_frame_poses.json: the fit of a frame still lands at the same view."""
    from research.frame_pairs.poses import load_fitted_poses

    stored = load_fitted_poses()
    assert len(stored) == 92
    frame = np.asarray(Image.open(GAZEBO_FRAME).convert("RGB"))
    index = 16  # sim-image-3-00160.png, the 17th frame in file order
    fitted = fit_pose(frame, RouteLines(np.load(ROUTE)), seed=index)
    at_stored, at_fit = render_at(ROUTE, [stored[index], (fitted.x_m, fitted.y_m, fitted.yaw_rad)])
    assert line_iou(at_stored, at_fit) > 0.8
    assert line_iou(frame, at_stored) > 0.5


@pytest.mark.slow
def test_the_study_on_two_frames_prints_pairs_per_real_checkpoint(tmp_path):
    picture = tmp_path / "pairs.png"
    result = CliRunner().invoke(
        frame_pairs_command,
        [
            "--data",
            str(SHARED_DATA),
            "--frames",
            "2",
            "--jobs",
            "1",
            "--picture",
            str(picture),
            "--save-poses",
            str(tmp_path / "poses.json"),
        ],
        catch_exceptions=False,
    )
    assert result.exit_code == 0, result.output
    report = json.loads([line for line in result.stdout.splitlines() if line.startswith("{")][-1])
    assert report["frames"] == 2 and len(report["poses"]) == 2
    assert set(report["policies"]) == {
        "gazebo-sample-reinvent2018/15_Step-0.ckpt",
        "gazebo-sample-reinvent2018/30_Step-0.ckpt",
    }
    for figures in report["policies"].values():
        assert 0.0 <= figures["pairs_all"] <= 1.0
        assert abs(sum(figures["shares_gazebo"].values()) - 1.0) < 0.01
    image = np.asarray(Image.open(picture))
    assert image.shape[0] == 120 and image.shape[1] > 320
    assert json.loads((tmp_path / "poses.json").read_text())["poses"] == report["poses"]
    assert set(report["grey"]["band_means_racer_vs_gazebo"]) == {"rows 0-40", "rows 40-80", "rows 80-120"}
