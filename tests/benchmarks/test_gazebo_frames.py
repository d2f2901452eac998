"""DeepRacer's reference frames and racer's frames at chosen poses (`python -m benchmarks transfer --racer-model`, `racer model
explain --racer-frames`)."""

from __future__ import annotations

import click
import numpy as np
import pytest
from PIL import Image

from benchmarks.gazebo_frames import GAZEBO_FRAMES, load_gazebo_frames, render_lap


def test_a_folder_without_frames_is_an_error_naming_it(tmp_path):
    with pytest.raises(click.ClickException, match=f"no Gazebo frames .* in {tmp_path}: expected the folder"):
        load_gazebo_frames(tmp_path)


def test_a_frame_of_another_size_is_an_error_naming_it(tmp_path):
    Image.fromarray(np.zeros((120, 160, 3), np.uint8)).save(tmp_path / "a.png")
    Image.fromarray(np.zeros((480, 640, 3), np.uint8)).save(tmp_path / "b.png")
    with pytest.raises(click.ClickException, match=r"b\.png: expected a 160x120 frame, got 640x480"):
        load_gazebo_frames(tmp_path)


def test_the_real_frames_load_in_file_order(deepracer_data):
    frames = load_gazebo_frames(deepracer_data / GAZEBO_FRAMES)
    assert frames.shape == (92, 120, 160, 3) and frames.dtype == np.uint8
    first = np.asarray(Image.open(sorted((deepracer_data / GAZEBO_FRAMES).glob("*.png"))[0]).convert("RGB"))
    np.testing.assert_array_equal(frames[0], first)


def test_racer_frames_round_a_shipped_track_need_no_data_folder():
    frames, ms_per_frame = render_lap("racer_oval", "base", 3, full_resolution=False)
    assert frames.shape == (3, 120, 160, 3) and ms_per_frame > 0
    assert len({frame.tobytes() for frame in frames}) == 3  # three places round the lap, three views
