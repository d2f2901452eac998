"""`racer model explain`: Grad-CAM / saliency maps of a policy's greedy action drawn over camera frames, for a fresh
racer model in a store and for a real DeepRacer checkpoint (a frozen graph trained in Gazebo) on a real Gazebo frame."""

from __future__ import annotations

import importlib.util
import json
import shutil

import numpy as np
import pytest
import torch
from click.testing import CliRunner
from PIL import Image

from racer.cli import main
from racer.model_io.explain import PANEL_SCALE, explain_frames, run_explain, title_height
from racer.model_io.explain_inputs import load_frames, open_model
from racer.shared.deepracer.model_metadata import parse_model_metadata
from racer.shared.policy.checkpoints import CheckpointStore
from racer.shared.policy.networks import build_actor_critic
from racer.shared.store import LocalStore
from tests.shared_data import SHARED_DATA

SAMPLE = SHARED_DATA / "models" / "gazebo-sample-reinvent2018"
GAZEBO_FRAMES = SHARED_DATA / "frames" / "gazebo_reinvent_episode"
CAMERA = "FRONT_FACING_CAMERA"
PANEL_SIZE = (160 * PANEL_SCALE, 120 * PANEL_SCALE + title_height())


def _fresh_model(store_root):
    """An untrained racer model with the sample's 12 actions, saved in a local store as `fresh`."""
    metadata = parse_model_metadata(json.loads((SAMPLE / "model_metadata.json").read_text()))
    torch.manual_seed(0)
    network = build_actor_critic(metadata)
    checkpoints = CheckpointStore(LocalStore(store_root), "fresh")
    checkpoints.put_model_metadata(metadata)
    checkpoints.save(0, 0, network, model_metadata=metadata)
    return network


def _argmax(network, grey):
    with torch.no_grad():
        return network.distribution({CAMERA: torch.from_numpy(grey[..., None])}).probs.numpy().argmax(axis=1)


def _check_maps(maps, count):
    assert maps.shape == (count, 120, 160)
    assert np.isfinite(maps).all() and (maps >= 0).all()
    assert (maps.reshape(count, -1).sum(axis=1) > 0).all()


@pytest.mark.slow
@pytest.mark.parametrize("method", ["gradcam", "saliency"])
def test_a_fresh_racer_model_from_the_store(tmp_path, method):
    network = _fresh_model(tmp_path / "store")
    frames = sorted(GAZEBO_FRAMES.glob("*.png"))[:3]
    names, grey = load_frames(tuple(frames))
    assert names == [path.stem for path in frames] and grey.shape == (3, 120, 160) and grey.dtype == np.uint8

    explanation = explain_frames(network, grey, method, all_actions=True)
    np.testing.assert_array_equal(explanation.actions, _argmax(network, grey))
    _check_maps(explanation.maps, 3)
    assert explanation.all_maps.shape == (3, 12, 120, 160)
    np.testing.assert_allclose(explanation.all_maps[np.arange(3), explanation.actions], explanation.maps, atol=1e-9)

    out = tmp_path / "out"
    args = ["model", "explain", "fresh", *map(str, frames[:2]), "--store", str(tmp_path / "store"), "--out", str(out)]
    result = CliRunner().invoke(main, [*args, "--method", method], catch_exceptions=False)
    assert result.exit_code == 0, result.output
    summary = json.loads(result.stdout.strip().splitlines()[-1])
    assert summary["frames"] == 2 and summary["method"] == method and summary["checkpoint"] == "0_Step-0.ckpt"
    assert summary["empty_maps"] == 0
    assert summary["attention"]["upper_half"] + summary["attention"]["lower_half"] == pytest.approx(1.0, abs=2e-3)
    assert sum(summary["steering_shares"].values()) == pytest.approx(1.0, abs=2e-3)
    for k, path in enumerate(frames[:2]):
        assert Image.open(out / f"{k:03d}-{path.stem}.png").size == PANEL_SIZE
    assert Image.open(out / "explain.png").size == (2 * 320, 240 + title_height(2))
    records = json.loads((out / "explain.json").read_text())
    assert [record["action"] for record in records] == _argmax(network, grey[:2]).tolist()


@pytest.mark.slow
def test_racer_frames_and_every_action(tmp_path):
    _fresh_model(tmp_path / "store")
    out = tmp_path / "out"
    result = CliRunner().invoke(
        main,
        ["model", "explain", "fresh", "--racer-frames", "2", "--all-actions", "--store", str(tmp_path / "store")]
        + ["--out", str(out)],
        catch_exceptions=False,
    )
    assert result.exit_code == 0, result.output
    assert json.loads(result.stdout.strip().splitlines()[-1])["frames"] == 2
    assert Image.open(out / "001-racer-base-001.png").size == PANEL_SIZE
    assert Image.open(out / "000-racer-base-000-actions.png").size == (4 * PANEL_SIZE[0], 3 * PANEL_SIZE[1])


def test_frames_of_other_sizes_and_grey_images_become_the_camera_input(tmp_path):
    Image.fromarray(np.full((480, 640, 3), 200, np.uint8)).save(tmp_path / "big.jpg")
    Image.fromarray(np.full((120, 160), 77, np.uint8)).save(tmp_path / "grey.png")
    names, grey = load_frames((tmp_path,))
    assert names == ["big", "grey"] and grey.shape == (2, 120, 160)
    assert grey[1].min() == grey[1].max() == 77  # a grey image is taken as it is


def test_racer_frames_of_a_missing_track_are_a_usage_error_naming_it(tmp_path):
    """The frames need no data beside the checkout: the default is a shipped track, and a missing one is named."""
    arguments = ["model", "explain", "fresh", "--racer-frames", "1", "--track", str(tmp_path / "nowhere.npy")]
    result = CliRunner().invoke(main, arguments + ["--store", str(tmp_path)])
    assert result.exit_code == 2 and "nowhere.npy" in result.output and "route file not found" in result.output


def test_nothing_to_explain_is_a_usage_error(tmp_path):
    result = CliRunner().invoke(main, ["model", "explain", "fresh", "--store", str(tmp_path)])
    assert result.exit_code == 2 and "--racer-frames" in result.output


@pytest.mark.slow
def test_the_real_deepracer_checkpoint_on_a_gazebo_frame(tmp_path):
    """model_30 alone (one TensorFlow import), through `racer model import`'s frozen-graph path."""
    folder = tmp_path / "model30"
    folder.mkdir()
    for name in ("model_metadata.json", "model_30.pb"):
        shutil.copy(SAMPLE / name, folder / name)
    frames = sorted(GAZEBO_FRAMES.glob("*.png"))[::30]
    names, grey = load_frames(tuple(frames))

    spec = importlib.util.spec_from_file_location(
        "drive_real_model", SHARED_DATA.parent / "tools" / "drive_real_model.py"
    )
    reference = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(reference)
    weights = reference.load_consts(str(SAMPLE / "model_30.pb"))
    expected = np.stack([reference.policy_probs(weights, frame) for frame in grey])  # numpy, no TensorFlow

    with open_model(str(folder), None, "best") as loaded:
        assert loaded.checkpoint == "30_Step-0.ckpt" and loaded.metadata.num_actions == 12
        summary = run_explain(loaded, names, grey, tmp_path / "out", "gradcam", all_actions=False)
        saliency = explain_frames(loaded.network, grey, "saliency")
        np.testing.assert_array_equal(saliency.actions, _argmax(loaded.network, grey))
    records = json.loads((tmp_path / "out" / "explain.json").read_text())
    assert [record["action"] for record in records] == expected.argmax(axis=1).tolist()
    assert summary["frames"] == len(frames) and summary["empty_maps"] == 0
    assert summary["mean_greedy_probability"] == pytest.approx(expected.max(axis=1).mean(), abs=2e-3)
    _check_maps(saliency.maps, len(frames))
    for k, name in enumerate(names):
        assert Image.open(tmp_path / "out" / f"{k:03d}-{name}.png").size == PANEL_SIZE
        assert sum(records[k]["attention"][key] for key in ("left_third", "centre_third", "right_third")) == (
            pytest.approx(1.0)
        )
        assert records[k]["mass"] > 0
