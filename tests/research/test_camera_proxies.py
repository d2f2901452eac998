"""The camera proxy (research/camera_proxies): racer's frames against DeepRacer's Gazebo frames, and a policy's steering on them."""

from __future__ import annotations

import json

import pytest

from racer.shared.sim.sensors.camera import rgb_to_y


@pytest.mark.slow
def test_camera_proxy_prints_one_json_line(deepracer_data):
    from click.testing import CliRunner

    from research.camera_proxies.camera import camera_command

    arguments = ["--data", str(deepracer_data), "--poses", "8", "--worlds", "base"]
    result = CliRunner().invoke(camera_command, arguments)
    assert result.exit_code == 0, result.output
    report = json.loads(result.output.strip().splitlines()[-1])
    base = report["worlds"]["base"]
    assert report["gazebo_frames"] == 92
    assert 0 <= base["histogram_emd"] < 20
    assert base["default_frame_ms"] > 0 and base["full_resolution_frame_ms"] > 0
    assert abs(base["upper_third_mean"] - report["gazebo_upper_third_mean"]) < 15
    # on the pairs (racer's frames at the Gazebo frames' fitted poses) the views match, so the look alone differs
    paired = base["paired"]
    assert paired["histogram_emd"] < 10
    for racer_mean, gazebo_mean in paired["band_means_racer_vs_gazebo"].values():
        assert abs(racer_mean - gazebo_mean) < 10


def test_camera_proxy_reports_a_policys_steering_shares(deepracer_data, tmp_path):
    """--checkpoint: a model folder in racer's store layout; its newest checkpoint steers on the 92 Gazebo frames."""
    import torch

    from benchmarks.gazebo_frames import GAZEBO_FRAMES, load_gazebo_frames
    from racer.shared.config import LocalStoreSettings
    from racer.shared.policy.checkpoints import CheckpointStore
    from racer.shared.policy.networks import build_actor_critic
    from racer.shared.sim.config import DEFAULT_MODEL_METADATA
    from racer.shared.store import open_store
    from research.camera_proxies.camera import policy_shares

    torch.manual_seed(0)
    checkpoints = CheckpointStore(open_store(LocalStoreSettings(root=tmp_path)), "m")
    checkpoints.put_model_metadata(DEFAULT_MODEL_METADATA)
    checkpoints.save(1, 100, build_actor_critic(DEFAULT_MODEL_METADATA), model_metadata=DEFAULT_MODEL_METADATA)
    frames = load_gazebo_frames(deepracer_data / GAZEBO_FRAMES)
    shares = policy_shares(tmp_path / "m", frames)
    assert set(shares) == {"left", "straight", "right"}
    assert abs(sum(shares.values()) - 1.0) < 0.01
    network = checkpoints.load_policy()
    first, _ = network.act({"FRONT_FACING_CAMERA": rgb_to_y(frames[0])[:, :, None]}, greedy=True)
    steering = DEFAULT_MODEL_METADATA.discrete_actions[int(first)].steering_angle_deg
    side = "straight" if steering == 0 else ("left" if steering > 0 else "right")
    assert shares[side] >= 1 / len(frames)
