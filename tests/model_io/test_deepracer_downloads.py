"""`racer model export` for the car and DRoA, and `racer model import` of DRoA's three download types, as a user
runs them: the exports validate with no problem, the imports evaluate and clone. TensorFlow runs in processes of
its own (the CLI's conversions); this test process renders (the evaluation) and never imports TensorFlow."""

from __future__ import annotations

import io
import json
import shutil
import tarfile
import zipfile
from pathlib import Path

import numpy as np
import pytest
import torch
from click.testing import CliRunner

from racer.cli import main
from racer.model_io import cli as model_cli
from racer.model_io import validate_location
from racer.shared.deepracer.hyperparameters import parse_hyperparameters
from racer.shared.deepracer.model_metadata import parse_model_metadata
from racer.shared.policy.checkpoints import (
    CheckpointError,
    CheckpointInfo,
    CheckpointStore,
)
from racer.shared.policy.networks import build_actor_critic
from racer.shared.store import LocalStore
from tests.model_io.model_io_builders import real_files

pytestmark = pytest.mark.slow

METADATA = {
    "action_space": [{"steering_angle": angle, "speed": 1.0} for angle in (-30, 0, 30)],
    "sensor": ["FRONT_FACING_CAMERA"],
    "neural_network": "DEEP_CONVOLUTIONAL_NETWORK_SHALLOW",
    "version": "5",
}


def frames(count: int = 10) -> dict[str, torch.Tensor]:
    rng = np.random.default_rng(2)
    return {"FRONT_FACING_CAMERA": torch.from_numpy(rng.integers(0, 256, (count, 120, 160, 1)).astype(np.float32))}


def policy_of(store: LocalStore, prefix: str, name: str) -> np.ndarray:
    with torch.inference_mode():
        return CheckpointStore(store, prefix).load_policy(name).policy_output(frames()).numpy()


def run(*args: str):
    return CliRunner().invoke(main, list(args), catch_exceptions=False)


@pytest.fixture(scope="module")
def trained(tmp_path_factory) -> dict:
    """A racer model `m` (two checkpoints, the second the best) and its two exports: racer layout and DRoA's."""
    root = tmp_path_factory.mktemp("downloads")
    store = LocalStore(root / "store")
    metadata = parse_model_metadata(METADATA, "METADATA")
    hyperparameters, _ = parse_hyperparameters(json.loads(real_files().hyperparameters), "hyperparameters.json")
    checkpoints = CheckpointStore(store, "m")
    checkpoints.put_model_metadata(metadata)
    checkpoints.put_hyperparameters(hyperparameters)
    store.put_bytes("m/reward_function.py", real_files().reward_function)
    store.put_bytes("m/training_params.yaml", real_files().training_params)
    store.put_bytes("m/metrics/TrainingMetrics.json", real_files().training_metrics)
    for number in range(2):
        torch.manual_seed(number)
        network = build_actor_critic(metadata)
        with torch.no_grad():
            network.policy_head.weight.normal_(0.0, 0.1)
        checkpoints.save(number, 100 * (number + 1), network, model_metadata=metadata, hyperparameters=hyperparameters)
    checkpoints.record_evaluation("1_Step-200.ckpt", 60.0, 5.0)
    result = run("model", "export", "m", str(root / "racer-export"), "--store", str(root / "store"))
    assert result.exit_code == 0, result.output
    assert "agent/model.pb" in result.output
    result = run("model", "export", "m", str(root / "droa-export"), "--store", str(root / "store"), "--for", "droa")
    assert result.exit_code == 0, result.output
    return {"root": root, "store": store, "expected": policy_of(store, "m", "1_Step-200.ckpt")}


def test_exports_validate_with_no_problem_and_look_like_deepracers(trained):
    root = trained["root"]
    for folder in ("racer-export", "droa-export"):
        report, _ = validate_location(str(root / folder))
        assert report.ok and not report.problems, (folder, report.problems)
        with tarfile.open(root / folder / "model.tar.gz") as bundle:
            assert sorted(bundle.getnames()) == ["agent/model.pb", "model_metadata.json"]
    droa = sorted(
        path.relative_to(root / "droa-export").as_posix()
        for path in (root / "droa-export").rglob("*")
        if path.is_file()
    )
    assert droa == [
        "hyperparameters.json",
        "metrics/training/training-TrainingMetrics.json",
        "model.tar.gz",
        "model/.coach_checkpoint",
        "model/1_Step-200.ckpt.data-00000-of-00001",
        "model/1_Step-200.ckpt.index",
        "model/1_Step-200.ckpt.meta",
        "model/deepracer_checkpoints.json",
        "model/model_1.pb",
        "model/model_metadata.json",
        "model_metadata.json",
        "reward_function.py",
        "training_params.yaml",
    ]
    racer = {path.name for path in (root / "racer-export" / "model").iterdir()}
    assert {"1_Step-200.ckpt.index", "1_Step-200.ckpt.weights.safetensors", "model_1.pb", "model_1.onnx"} <= racer


def droa_virtual_model(folder: Path, archive: Path, as_zip: bool) -> Path:
    """DRoA's "virtual model" download: the import folder packed as ZIP (<= 1.0.9) or tar.gz (>= 1.0.10), both
    named .tar.gz."""
    files = sorted(path for path in folder.rglob("*") if path.is_file() and path.name != "model.tar.gz")
    if as_zip:
        with zipfile.ZipFile(archive, "w") as packed:
            for path in files:
                packed.write(path, path.relative_to(folder).as_posix())
    else:
        with tarfile.open(archive, "w:gz") as packed:
            for path in files:
                packed.add(path, path.relative_to(folder).as_posix())
    return archive


def test_a_zip_virtual_model_named_tar_gz_imports_evaluates_and_clones(trained, tmp_path):
    archive = droa_virtual_model(trained["root"] / "droa-export", tmp_path / "virtual-model.tar.gz", as_zip=True)
    result = run("model", "import", str(archive), "from-zip", "--store", str(tmp_path / "store"))
    assert result.exit_code == 0, result.output
    assert "converted 1_Step-200.ckpt to racer checkpoints" in result.output
    store = LocalStore(tmp_path / "store")
    np.testing.assert_allclose(policy_of(store, "from-zip", "1_Step-200.ckpt"), trained["expected"], atol=1e-6)
    # --pretrained-prefix: the trainer restores the last checkpoint's weights into a fresh network.
    network = build_actor_critic(parse_model_metadata(METADATA, "METADATA"))
    clone = CheckpointStore(store, "from-zip")
    clone.restore(clone.select("last"), network)
    with torch.inference_mode():
        np.testing.assert_allclose(network.eval().policy_output(frames()).numpy(), trained["expected"], atol=1e-6)
    evaluation = CliRunner().invoke(
        main,
        [
            "evaluate",
            "--model-prefix",
            "from-zip",
            "--mode",
            "race",
            "--race-minutes",
            "0.05",
            "--no-video",
            "--no-mcap",
        ],
        env={"RACER_STORE": str(tmp_path / "store")},
        catch_exceptions=False,
    )
    assert evaluation.exit_code == 0, evaluation.output


def test_a_tar_gz_virtual_model_and_a_training_logs_tarball_import(trained, tmp_path):
    """DRoA >= 1.0.10 writes a real tar.gz; a logs tarball that carries the model folder deeper is searched."""
    source = trained["root"] / "droa-export"
    archive = tmp_path / "training-logs.tar.gz"
    with tarfile.open(archive, "w:gz") as packed:
        log = b"Training> Name=main_level/agent, Worker=0, Episode=1\n"
        info = tarfile.TarInfo("logs/training/robomaker.log")
        info.size = len(log)
        packed.addfile(info, io.BytesIO(log))
        for path in sorted(source.rglob("*")):
            if path.is_file():
                packed.add(path, f"models/m/{path.relative_to(source).as_posix()}")
    result = run("model", "import", str(archive), "from-logs", "--store", str(tmp_path / "store"))
    assert result.exit_code == 0, result.output
    assert "models/m" in result.output
    np.testing.assert_allclose(
        policy_of(LocalStore(tmp_path / "store"), "from-logs", "1_Step-200.ckpt"), trained["expected"], atol=1e-6
    )


def test_the_physical_car_tarball_imports_with_a_fresh_value_network(trained, tmp_path):
    bundle = shutil.copy(trained["root"] / "racer-export" / "model.tar.gz", tmp_path / "car.tar.gz")
    result = run("model", "import", str(bundle), "from-car", "--store", str(tmp_path / "store"))
    assert result.exit_code == 0, result.output
    assert "value network starts fresh" in result.output
    store = LocalStore(tmp_path / "store")
    np.testing.assert_allclose(policy_of(store, "from-car", "0_Step-0.ckpt"), trained["expected"], atol=1e-6)
    assert CheckpointStore(store, "from-car").select("best") == "0_Step-0.ckpt"


def test_a_logs_only_tarball_says_it_holds_no_model(tmp_path):
    archive = tmp_path / "logs.tar.gz"
    with tarfile.open(archive, "w:gz") as packed:
        info = tarfile.TarInfo("logs/training/robomaker.log")
        info.size = 3
        packed.addfile(info, io.BytesIO(b"log"))
    result = run("model", "import", str(archive), "logs", "--store", str(tmp_path / "store"))
    assert result.exit_code == 1
    assert "no model weights here" in result.output


def test_without_tensorflow_export_and_import_say_how_to_get_it(trained, tmp_path, monkeypatch):
    monkeypatch.setattr(model_cli, "tensorflow_available", lambda: False)
    result = run("model", "export", "m", str(tmp_path / "out"), "--store", str(trained["root"] / "store"))
    assert result.exit_code == 0, result.output
    assert "pip install -e '.[tensorflow]'" in result.output
    result = run(
        "model", "export", "m", str(tmp_path / "droa"), "--store", str(trained["root"] / "store"), "--for", "droa"
    )
    assert result.exit_code == 1 and "pip install -e '.[tensorflow]'" in result.output
    bundle = trained["root"] / "racer-export" / "model.tar.gz"
    result = run("model", "import", str(bundle), "car", "--store", str(tmp_path / "store"))
    assert result.exit_code == 1 and "pip install -e '.[tensorflow]'" in result.output


def test_a_continuous_checkpoint_with_a_tanh_mean_is_refused_clearly():
    """A continuous checkpoint whose manifest lacks `continuous_mean` "linear" squashed its mean with tanh, unlike
    DeepRacer's linear mean: it is refused."""
    manifest = {
        "format": "racer-checkpoint-1",
        "name": "3_Step-9.ckpt",
        "number": 3,
        "env_steps": 9,
        "policy_config": {
            "neural_network": "DEEP_CONVOLUTIONAL_NETWORK_SHALLOW",
            "action_space_type": "continuous",
            "num_actions": 2,
            "inputs": [{"name": "FRONT_FACING_CAMERA", "kind": "camera", "shape": [120, 160, 1]}],
        },
        "created_unix_s": 0.0,
        "files": {},
    }
    with pytest.raises(CheckpointError, match="tanh"):
        CheckpointInfo.from_dict(manifest)
    assert CheckpointInfo.from_dict({**manifest, "continuous_mean": "linear"}).policy_config.is_continuous
