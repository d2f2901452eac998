"""DeepRacer's numbered frozen graphs (`model_<N>.pb` beside model_metadata.json, as DeepRacer keeps them) import as
one racer checkpoint each, and each imported policy gives the graph's own probabilities on DeepRacer's Gazebo frames
(checked against ../shared/tools/drive_real_model.py, which reads the graph's weights into numpy without TensorFlow)."""

from __future__ import annotations

import importlib.util

import numpy as np
import pytest
import torch
from click.testing import CliRunner
from PIL import Image

from racer.cli import main
from racer.model_io.deepracer_import import frozen_graph_keys, graph_checkpoint_number
from racer.shared.policy.checkpoints import CheckpointStore
from racer.shared.store import LocalStore
from tests.shared_data import SHARED_DATA

SAMPLE = SHARED_DATA / "models" / "gazebo-sample-reinvent2018"
CAMERA = "FRONT_FACING_CAMERA"


def test_numbered_graphs_are_found_at_the_root_and_under_model():
    files = {"model_metadata.json": 1, "model_30.pb": 1, "model_15.pb": 1}
    assert frozen_graph_keys(files) == ("model_15.pb", "model_30.pb")
    assert frozen_graph_keys({"model/model_metadata.json": 1, "model/model_7.pb": 1}) == ("model/model_7.pb",)
    assert frozen_graph_keys({"agent/model.pb": 1, "model_metadata.json": 1}) == ("agent/model.pb",)
    assert frozen_graph_keys({"model_30.pb": 1}) == ()  # no metadata: not a model
    assert graph_checkpoint_number("model/model_30.pb") == 30 and graph_checkpoint_number("agent/model.pb") == 0


def _reference_forward():
    spec = importlib.util.spec_from_file_location(
        "drive_real_model", SHARED_DATA.parent / "tools" / "drive_real_model.py"
    )
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.slow
def test_the_gazebo_sample_imports_each_checkpoint_with_the_graphs_own_policy(tmp_path):
    result = CliRunner().invoke(main, ["model", "import", str(SAMPLE), "gazebo-sample", "--store", str(tmp_path)])
    assert result.exit_code == 0, result.output
    checkpoints = CheckpointStore(LocalStore(tmp_path), "gazebo-sample")
    assert checkpoints.names() == ["15_Step-0.ckpt", "30_Step-0.ckpt"]
    assert checkpoints.latest_name() == "30_Step-0.ckpt"

    reference = _reference_forward()
    frames = sorted((SHARED_DATA / "frames" / "gazebo_reinvent_episode").glob("*.png"))[::10]
    grey = np.stack([np.asarray(Image.open(path).convert("L")) for path in frames])
    for number in (15, 30):
        weights = reference.load_consts(str(SAMPLE / f"model_{number}.pb"))
        expected = np.stack([reference.policy_probs(weights, frame) for frame in grey])
        network = checkpoints.load_policy(f"{number}_Step-0.ckpt")
        with torch.no_grad():
            got = network.distribution({CAMERA: torch.from_numpy(grey[..., None])}).probs.numpy()
        np.testing.assert_allclose(got, expected, atol=2e-5)
        assert (got.argmax(axis=1) == expected.argmax(axis=1)).all()
