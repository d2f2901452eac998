"""racer's own checkpoints: export -> validate -> import -> load gives the same greedy actions, training can clone
the import, the car bundle's ONNX agrees, and edits to checkpoint files or metadata are caught."""

from __future__ import annotations

import io
import json
import shutil
import tarfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import onnxruntime
import pytest
import torch
from click.testing import CliRunner

from racer.cli import main
from racer.model_io import (
    FolderDestination,
    FolderSource,
    ProblemCode,
    export_model,
    import_model,
    validate_location,
)
from racer.model_io.checkpoints import checkpoint_files, is_racer_checkpoint, missing_parts
from racer.shared.deepracer.hyperparameters import parse_hyperparameters
from racer.shared.deepracer.model_metadata import parse_model_metadata
from racer.shared.model_layout import RACER_CHECKPOINT_SUFFIXES, CheckpointName
from racer.shared.policy.checkpoints import CheckpointStore
from racer.shared.policy.networks import ActorCritic, build_actor_critic
from racer.shared.store import LocalStore
from tests.model_io.model_io_builders import real_files

pytestmark = pytest.mark.usefixtures("deepracer_data")  # the builders read ../shared/deepracer-data

Code = ProblemCode

METADATA = {
    "action_space": [
        {"steering_angle": -30, "speed": 1.0},
        {"steering_angle": 0, "speed": 2.0},
        {"steering_angle": 30, "speed": 1.0},
    ],
    "sensor": ["FRONT_FACING_CAMERA"],
    "neural_network": "DEEP_CONVOLUTIONAL_NETWORK_DEEP",  # the smallest of the three (1152-wide flatten)
    "version": "5",
}


def observations(count: int, seed: int) -> list[dict[str, np.ndarray]]:
    """Camera frames with a bright rectangle on a darker background: varied enough that a network's greedy
    action changes from frame to frame (uniform noise frames all look alike to a conv net)."""
    rng = np.random.default_rng(seed)
    frames = []
    for _ in range(count):
        image = np.full((120, 160, 1), rng.integers(0, 120), dtype=np.uint8)
        (x0, x1), (y0, y1) = sorted(rng.integers(0, 160, 2)), sorted(rng.integers(0, 120, 2))
        image[y0 : y1 + 1, x0 : x1 + 1] = rng.integers(120, 256)
        frames.append({"FRONT_FACING_CAMERA": image})
    return frames


def greedy_actions(network: ActorCritic, batch: list[dict[str, np.ndarray]]) -> list[int]:
    return [network.act(observation, greedy=True)[0] for observation in batch]


@dataclass(frozen=True)
class Trained:
    store: LocalStore
    states: dict[str, dict[str, torch.Tensor]]
    """Weights of every saved checkpoint, kept in memory when it was saved."""
    exported: Path
    """`racer model export` of the run, written once for the module."""


def network_with(state: dict[str, torch.Tensor]) -> ActorCritic:
    network = build_actor_critic(parse_model_metadata(METADATA, "METADATA"))
    network.load_state_dict(state)
    return network.eval()


@pytest.fixture(scope="module")
def trained(tmp_path_factory) -> Trained:
    """A racer training run in a store: three checkpoints, each pushed towards a different action, best = 1."""
    store = LocalStore(tmp_path_factory.mktemp("trained-store"))
    metadata = parse_model_metadata(METADATA, "METADATA")
    hyperparameters, _ = parse_hyperparameters(json.loads(real_files().hyperparameters), "hyperparameters.json")
    torch.manual_seed(0)
    network = build_actor_critic(metadata)
    optimizer = torch.optim.Adam(network.parameters(), lr=3e-4, eps=1e-5)
    checkpoints = CheckpointStore(store, "trained")
    checkpoints.put_model_metadata(metadata)
    checkpoints.put_hyperparameters(hyperparameters)
    store.put_bytes("trained/reward_function.py", real_files().reward_function)
    store.put_bytes("trained/training_params.yaml", real_files().training_params)
    store.put_bytes("trained/metrics/TrainingMetrics.json", real_files().training_metrics)
    # One optimiser step so the checkpoints carry Adam moments, then each checkpoint gets weights of its own
    # (a differently seeded network), as if training had moved them: checkpoints must not act alike.
    images = torch.from_numpy(np.stack([frame["FRONT_FACING_CAMERA"] for frame in observations(8, seed=1)]))
    loss = -network.distribution({"FRONT_FACING_CAMERA": images}).log_prob(torch.zeros(8, dtype=torch.long)).mean()
    loss.backward()
    optimizer.step()
    states = {}
    for number in range(3):
        torch.manual_seed(10 + number)
        with torch.no_grad():
            for parameter, value in zip(network.parameters(), build_actor_critic(metadata).parameters(), strict=True):
                parameter.copy_(value)
        name = checkpoints.save(number, 500 * number, network, optimizer, metadata, hyperparameters)
        states[name] = {key: value.detach().clone() for key, value in network.state_dict().items()}
    checkpoints.record_evaluation("1_Step-500.ckpt", 80.0, 10.0)
    checkpoints.record_evaluation("2_Step-1000.ckpt", 50.0, 20.0)
    exported = tmp_path_factory.mktemp("exported") / "trained"
    result = export_model(store, "trained", FolderDestination(exported))
    assert result.ok, (result.report.problems, result.problems, result.check)
    return Trained(store, states, exported)


@pytest.fixture
def exported_copy(trained, tmp_path) -> Path:
    return Path(shutil.copytree(trained.exported, tmp_path / "copy"))


def test_validation_knows_every_file_the_checkpoint_store_writes(trained):
    files = {
        str(path.relative_to(trained.exported)): path.stat().st_size
        for path in trained.exported.rglob("*")
        if path.is_file()
    }
    name = CheckpointName.parse("2_Step-1000.ckpt")
    written = checkpoint_files(name, files)
    assert written and is_racer_checkpoint(name, files) and missing_parts(name, files) == []
    assert {key.removeprefix(name.file("")) for key in written} <= set(RACER_CHECKPOINT_SUFFIXES)


def test_export_import_load_gives_the_same_greedy_actions(trained, tmp_path):
    report, source = validate_location(str(trained.exported))
    assert report.ok, report.problems
    assert report.plan.selection.checkpoints == ("1_Step-500.ckpt", "2_Step-1000.ckpt")
    assert report.plan.selection.best == "1_Step-500.ckpt"

    other = LocalStore(tmp_path / "other-store")
    assert import_model(source, other, "imported").ok
    imported = CheckpointStore(other, "imported")
    assert imported.select("best") == "1_Step-500.ckpt"
    assert imported.select("last") == "2_Step-1000.ckpt"
    batch = observations(12, seed=7)
    for name in ("1_Step-500.ckpt", "2_Step-1000.ckpt"):
        expected = greedy_actions(network_with(trained.states[name]), batch)
        assert greedy_actions(imported.load_policy(name), batch) == expected
        # What `racer evaluate` acts with: the imported checkpoint's ONNX model under ONNX Runtime.
        assert greedy_actions(imported.load_inference_policy(name), batch) == expected
    # The two checkpoints act differently, so loading the wrong one could not pass the comparison above.
    assert greedy_actions(imported.load_policy("1_Step-500.ckpt"), batch) != greedy_actions(
        imported.load_policy("2_Step-1000.ckpt"), batch
    )


def test_the_car_bundle_runs_the_best_checkpoint(trained):
    with tarfile.open(trained.exported / "model.tar.gz") as bundle:
        assert sorted(bundle.getnames()) == ["agent/model.onnx", "model_metadata.json"]
        onnx_bytes = bundle.extractfile("agent/model.onnx").read()
        metadata = json.loads(bundle.extractfile("model_metadata.json").read())
    assert parse_model_metadata(metadata, "bundle").num_actions == 3
    session = onnxruntime.InferenceSession(onnx_bytes, providers=["CPUExecutionProvider"])
    (model_input,) = session.get_inputs()
    assert model_input.name == "FRONT_FACING_CAMERA" and list(model_input.shape) == [1, 120, 160, 1]
    batch = observations(12, seed=11)
    car_actions = []
    for frame in batch:
        (probabilities,) = session.run(
            None, {"FRONT_FACING_CAMERA": frame["FRONT_FACING_CAMERA"][None].astype(np.float32)}
        )
        car_actions.append(int(np.argmax(probabilities)))
    assert car_actions == greedy_actions(network_with(trained.states["1_Step-500.ckpt"]), batch)


def test_training_can_clone_and_resume_from_the_import(trained, tmp_path):
    other = LocalStore(tmp_path / "other-store")
    assert import_model(FolderSource(trained.exported), other, "to-clone").ok
    imported = CheckpointStore(other, "to-clone")
    network = build_actor_critic(parse_model_metadata(METADATA, "METADATA"))
    imported.restore(imported.select("best"), network)  # clone: weights only
    for key, value in trained.states["1_Step-500.ckpt"].items():
        assert torch.equal(network.state_dict()[key], value), key
    optimizer = torch.optim.Adam(network.parameters(), lr=1e-3, eps=1e-5)
    assert imported.restore("2_Step-1000.ckpt", network, optimizer) == (2, 1000)  # resume: weights + Adam state
    assert optimizer.state_dict()["state"], "the Adam moments came through the round trip"


def flip_one_byte(path: Path) -> None:
    data = bytearray(path.read_bytes())
    data[len(data) // 2] ^= 0xFF
    path.write_bytes(bytes(data))


EDITS = {
    "weights changed": (
        lambda root: flip_one_byte(root / "model/2_Step-1000.ckpt.weights.safetensors"),
        Code.MODEL_VALIDATION_SERVICE_ERROR,
    ),
    "inference model changed": (
        lambda root: flip_one_byte(root / "model/model_1.onnx"),
        Code.MODEL_VALIDATION_SERVICE_ERROR,
    ),
    "manifest is not a manifest": (
        lambda root: (root / "model/1_Step-500.ckpt.json").write_text('{"format": "x"}'),
        Code.MODEL_VALIDATION_SERVICE_ERROR,
    ),
    "optimiser state deleted": (
        lambda root: (root / "model/2_Step-1000.ckpt.optimizer.safetensors").unlink(),
        Code.CHECKPOINT_FILES_DOES_NOT_EXIST,
    ),
    "manifest deleted": (
        lambda root: (root / "model/1_Step-500.ckpt.json").unlink(),
        Code.CHECKPOINT_FILES_DOES_NOT_EXIST,
    ),
    "weights deleted": (
        lambda root: (root / "model/2_Step-1000.ckpt.weights.safetensors").unlink(),
        Code.CHECKPOINT_FILES_DOES_NOT_EXIST,
    ),
}


@pytest.mark.parametrize("case", sorted(EDITS))
def test_edited_racer_checkpoints_are_caught(exported_copy, case):
    edit, expected = EDITS[case]
    edit(exported_copy)
    report, _ = validate_location(str(exported_copy))
    assert report.codes == [expected], [problem.render() for problem in report.problems]


def test_metadata_edited_to_another_action_space_is_caught(exported_copy):
    """A valid model_metadata.json, but not the one the network was trained with (5 actions instead of 3)."""
    edited = dict(METADATA, action_space=[{"steering_angle": angle, "speed": 1.0} for angle in (-30, -15, 0, 15, 30)])
    for key in ("model/model_metadata.json", "model_metadata.json"):
        (exported_copy / key).write_text(json.dumps(edited))
    with tarfile.open(exported_copy / "model.tar.gz") as bundle:  # keep the car bundle out of the picture
        onnx_bytes = bundle.extractfile("agent/model.onnx").read()
    buffer = io.BytesIO()
    with tarfile.open(fileobj=buffer, mode="w:gz") as bundle:
        for name, data in (("model_metadata.json", json.dumps(edited).encode()), ("agent/model.onnx", onnx_bytes)):
            info = tarfile.TarInfo(name)
            info.size = len(data)
            bundle.addfile(info, io.BytesIO(data))
    (exported_copy / "model.tar.gz").write_bytes(buffer.getvalue())
    report, _ = validate_location(str(exported_copy))
    assert report.codes == [Code.MODEL_VALIDATION_SERVICE_ERROR], [problem.render() for problem in report.problems]
    assert "5 discrete actions" in report.problems[0].message and "3 discrete actions" in report.problems[0].message


@pytest.mark.slow
def test_command_line_round_trip_through_a_bucket(trained, s3_settings, tmp_path):
    """racer model export -> s3://bucket/prefix -> racer model validate -> racer model import, all as a user would."""
    runner = CliRunner()
    env = {
        "S3_ENDPOINT_URL": s3_settings.endpoint_url,
        "AWS_ACCESS_KEY_ID": s3_settings.access_key_id,
        "AWS_SECRET_ACCESS_KEY": s3_settings.secret_access_key,
        "RACER_CONNECT_TIMEOUT_S": "5",
    }
    location = f"s3://{s3_settings.bucket}/exports/trained"
    result = runner.invoke(main, ["model", "export", "trained", location, "--store", str(trained.store.root)], env=env)
    assert result.exit_code == 0, result.output
    assert "agent/model.pb" in result.output  # the car bundle holds the frozen graph DeepRacer's cars load (issue 21)
    result = runner.invoke(main, ["model", "validate", location], env=env)
    assert result.exit_code == 0, result.output
    assert "best 1_Step-500.ckpt, last 2_Step-1000.ckpt" in result.output
    other = tmp_path / "other-store"
    result = runner.invoke(main, ["model", "import", location, "from-bucket", "--store", str(other)], env=env)
    assert result.exit_code == 0, result.output
    assert "--pretrained-prefix from-bucket" in result.output
    batch = observations(6, seed=3)
    policy = CheckpointStore(LocalStore(other), "from-bucket").load_policy("1_Step-500.ckpt")
    assert greedy_actions(policy, batch) == greedy_actions(network_with(trained.states["1_Step-500.ckpt"]), batch)
