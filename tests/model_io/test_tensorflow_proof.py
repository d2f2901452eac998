"""One function everywhere: racer's policy, the exported TensorFlow frozen graph, and the OpenVINO IR and LiteRT
(TFLite) models the cars make from it compute the same outputs on frames rendered by racer's simulator.

Every network (shallow, deep, deeper), every sensor set DRoA's model validation accepts, PPO discrete and
continuous and SAC. The full product is 72 models and the stereo DEEP networks are 230 MB each, which takes long on
2 cores: the suite runs 12 of them, each head (PPO discrete, PPO continuous, SAC) on every network, and the
embedders on every sensor set (the heads and the embedders are separate code, so the product adds no code path):
PPO on all 8 sensor sets, discrete and continuous in turn so that each head meets both cameras and every lidar, the
front-camera sets on the deep and deeper networks and the stereo ones on the shallow network, and the shallow
front-camera discrete model; SAC on the deep and deeper networks with the front camera and LIDAR, and on the shallow
one with stereo cameras and SECTOR_LIDAR. `python -m
tests.model_io.tf_proof` runs all 72 with the same code. SAC's graph output is
its mean before tanh, compared with racer's mean before tanh. TensorFlow, OpenVINO and LiteRT
run in one TensorFlow process, never in this process, which has rendered with Mesa.

Also: TensorFlow imports the real DeepRacer checkpoint's `.meta` graph and restores a checkpoint racer wrote for the
same model_metadata.json (9 actions, shallow, front camera) with its own saver, and its policy equals racer's.
"""

from __future__ import annotations

import json

import numpy as np
import pytest
import torch

from racer.model_io.tensorflow.coach_layout import (
    POLICY_OUTPUT_NODE,
    coach_variables,
    input_node,
)
from racer.model_io.tensorflow.convert import ExportJob, tensorflow_files
from racer.model_io.tensorflow.runner import run_tool
from racer.shared.deepracer.model_metadata import NEURAL_NETWORKS, parse_model_metadata
from racer.shared.policy.networks import build_actor_critic
from tests.model_io.model_io_builders import CONFIG
from tests.model_io.tf_proof import (
    FP16_SAME_ACTION,
    FP16_TOLERANCE,
    FP32_TOLERANCE,
    RUNTIMES,
    SENSOR_SETS,
    ModelSpec,
    all_specs,
    render_frames,
    run_proof,
    summarize,
)

# The module's fixture converts 12 models four ways, which on 2 busy cores can take longer than pytest's default
# 900 s per test.
pytestmark = [pytest.mark.slow, pytest.mark.timeout(2400)]

REAL_CHECKPOINT = CONFIG / "checkpoints" / "reInvent2019-TestModel" / "model"
FRAMES = 100
SHALLOW, DEEP, DEEPER = NEURAL_NETWORKS
FRONT = ("FRONT_FACING_CAMERA",)
FRONT_LIDAR = ("FRONT_FACING_CAMERA", "LIDAR")
FRONT_NETWORKS = {0: DEEP, 1: DEEP, 2: DEEPER, 3: DEEPER}
"""SENSOR_SETS' front-camera sets (index: network): the deep and deeper networks each meet both PPO heads and, between
them, every lidar; the 230 MB stereo DEEP networks stay out of the suite."""
PPO_SPECS = [
    ModelSpec(FRONT_NETWORKS.get(i, SHALLOW), sensors, continuous=(i + i // 4) % 2 == 1)
    for i, sensors in enumerate(SENSOR_SETS)
] + [ModelSpec(SHALLOW, FRONT, False)]
"""Discrete and continuous in turn over SENSOR_SETS (front camera, then stereo; no lidar, LIDAR, SECTOR_LIDAR,
DISCRETIZED_SECTOR_LIDAR): discrete on front, front+SECTOR_LIDAR, stereo+LIDAR, stereo+DISCRETIZED_SECTOR_LIDAR;
the stereo sets on the shallow network, and the shallow front-camera discrete model, DeepRacer's most common."""
SAC_SPECS = [ModelSpec(network, FRONT_LIDAR, True, True) for network in (DEEP, DEEPER)] + [
    ModelSpec(SHALLOW, ("STEREO_CAMERAS", "SECTOR_LIDAR"), True, True)
]
"""SAC differs from PPO in its head only (the embedders are the same code): every network once, the shallow one with
stereo cameras."""
SUITE_SPECS = PPO_SPECS + SAC_SPECS


@pytest.fixture(scope="module")
def frames() -> dict[str, np.ndarray]:
    return render_frames(FRAMES)


@pytest.fixture(scope="module")
def proof(frames) -> dict:
    """Two TensorFlow processes side by side: the conversions mostly use one core each (same models, same seeds)."""
    return run_proof(SUITE_SPECS, frames, processes=2)


def test_every_network_sensor_set_and_action_space_is_covered(proof):
    assert len(all_specs()) == 72 and len(set(SENSOR_SETS)) == 8
    keys = list(proof["expected"])
    assert len(keys) == 12 and set(keys) <= {spec.key for spec in all_specs()}
    assert {key.split(":")[1] for key in keys} == {"+".join(sensors) for sensors in SENSOR_SETS}
    lidars = {"", "LIDAR", "SECTOR_LIDAR", "DISCRETIZED_SECTOR_LIDAR"}
    for kind in ("discrete", "continuous", "sac"):
        networks, sensors = zip(*(key.split(":")[:2] for key in keys if key.endswith(f":{kind}")), strict=True)
        assert set(networks) == set(NEURAL_NETWORKS), kind
        if kind != "sac":  # each PPO head meets both cameras and every lidar
            assert {s.split("+")[0] for s in sensors} == {"FRONT_FACING_CAMERA", "STEREO_CAMERAS"}, kind
            assert {s.split("+")[1] if "+" in s else "" for s in sensors} == lidars, kind


@pytest.mark.parametrize("runtime", ["tensorflow", "openvino_fp32", "litert_fp32"])
def test_fp32_runtimes_agree_with_racer_to_1e5(proof, runtime):
    worst = {
        key: float(np.abs(proof["outputs"][f"{key}|{runtime}"] - expected).max())
        for key, expected in proof["expected"].items()
    }
    bad = {key: value for key, value in worst.items() if value > FP32_TOLERANCE}
    assert not bad, f"{runtime}: outputs differ from racer's by more than {FP32_TOLERANCE}: {bad}"


@pytest.mark.parametrize("runtime", ["openvino_fp16", "litert_fp16"])
def test_fp16_conversions_pick_the_same_action_and_agree_to_1e3(proof, runtime):
    for key, expected in proof["expected"].items():
        got = proof["outputs"][f"{key}|{runtime}"]
        assert float(np.abs(got - expected).max()) <= FP16_TOLERANCE, key
        if key.endswith("discrete"):
            same = float(np.mean(got.argmax(axis=1) == expected.argmax(axis=1)))
            assert same >= FP16_SAME_ACTION, f"{runtime} {key}: same greedy action on {same:.0%} of frames"
    assert summarize(proof)["goals_met"]


def test_the_frames_are_real_and_the_policies_are_not_constant(frames, proof):
    """The comparison means something: frames differ, and discrete policies choose different actions."""
    front = frames["FRONT_FACING_CAMERA"]
    assert front.shape == (FRAMES, 120, 160, 1) and frames["STEREO_CAMERAS"].shape == (FRAMES, 120, 160, 2)
    assert len({frame.tobytes() for frame in front}) > FRAMES // 2
    assert 20 < float(front.mean()) < 235
    discrete = {key: value for key, value in proof["expected"].items() if key.endswith("discrete")}
    varied = [key for key, value in discrete.items() if len(set(value.argmax(axis=1).tolist())) > 1]
    assert len(discrete) == 5 and len(varied) >= 3, varied  # at least half, as 6 of the 28 models' 12 were


def test_deepracer_restores_a_racer_checkpoint_into_its_own_graph(frames, tmp_path):
    """The SimApp's .meta graph (reInvent2019 test model: 9 actions, shallow, front camera) restores a checkpoint
    racer wrote with RL Coach's saver: no missing or mismatched variable, and the same policy."""
    metadata = parse_model_metadata(json.loads((REAL_CHECKPOINT / "model_metadata.json").read_text()), "real")
    torch.manual_seed(5)
    network = build_actor_critic(metadata).eval()
    files = tensorflow_files([ExportJob(network, "11_Step-38428.ckpt", None)])[0]
    for name, data in files.items():
        (tmp_path / name).write_bytes(data)
    camera = frames["FRONT_FACING_CAMERA"][:20]
    result, tensors = run_tool(
        "restore_meta",
        {
            "meta_path": str(REAL_CHECKPOINT / "11_Step-38428.ckpt.meta"),
            "checkpoint_prefix": str(tmp_path / "11_Step-38428.ckpt"),
            "inputs": [input_node("FRONT_FACING_CAMERA")],
            "output": POLICY_OUTPUT_NODE,
        },
        {input_node("FRONT_FACING_CAMERA"): camera},
    )
    assert result == {"missing": [], "mismatched": [], "restored": True}
    with torch.inference_mode():
        expected = network.policy_output({"FRONT_FACING_CAMERA": torch.from_numpy(camera)}).numpy()
    assert float(np.abs(tensors["policy"] - expected).max()) <= FP32_TOLERANCE


def test_racer_names_every_variable_of_the_real_checkpoint():
    """The 22 tensors of DeepRacer's checkpoint index, names and shapes, are what racer writes for that metadata."""
    metadata = parse_model_metadata(json.loads((REAL_CHECKPOINT / "model_metadata.json").read_text()), "real")
    result, _ = run_tool(
        "read_checkpoint", {"checkpoint_prefix": str(REAL_CHECKPOINT / "11_Step-38428.ckpt"), "values": False}
    )
    real = {name: tuple(item["shape"]) for name, item in result["variables"].items()}
    ours = {variable.name: variable.shape for variable in coach_variables(build_actor_critic(metadata).config)}
    assert len(real) == 22
    assert ours == real


def test_model_specs_name_each_model_once():
    assert len({spec.key for spec in all_specs()}) == 72
    assert ModelSpec(NEURAL_NETWORKS[0], ("STEREO_CAMERAS", "LIDAR"), True).key.endswith(
        "STEREO_CAMERAS+LIDAR:continuous"
    )


def test_processes_share_the_models_in_turn_and_keep_each_models_seed(monkeypatch):
    """`run_proof(processes=2)` (`python -m tests.model_io.tf_proof --processes 2`): model i goes to TensorFlow process i mod 2,
    both run side by side, and racer's side (weights from seed first_seed + i, expected outputs) is what one process
    gets; the answers are merged."""
    import threading

    from tests.model_io import tf_proof

    specs = [spec for spec in all_specs() if spec.neural_network == NEURAL_NETWORKS[0]][:5]
    rng = np.random.default_rng(0)
    frames = {
        "FRONT_FACING_CAMERA": rng.uniform(0, 255, (3, 120, 160, 1)).astype(np.float32),
        "STEREO_CAMERAS": rng.uniform(0, 255, (3, 120, 160, 2)).astype(np.float32),
        "LIDAR": rng.uniform(0.15, 1, (3, 64)).astype(np.float32),
        "SECTOR_LIDAR": rng.integers(0, 2, (3, 8)).astype(np.float32),
        "DISCRETIZED_SECTOR_LIDAR": rng.integers(0, 2, (3, 32)).astype(np.float32),
    }
    calls: list[list[str]] = []
    both_running = threading.Barrier(2, timeout=30)

    def fake_tool(command, request, arrays, timeout_s):
        keys = [model["key"] for model in request["models"]]
        calls.append(keys)
        if len(keys) < len(specs):
            both_running.wait()  # each process starts while the other still runs
        outputs = {f"{key}|tensorflow": np.full(3, index, np.float32) for index, key in enumerate(keys)}
        return {"cpu_s": {key: {"tensorflow": 0.5} for key in keys}}, outputs

    monkeypatch.setattr(tf_proof, "run_tool", fake_tool)
    together = run_proof(specs, frames, runtimes=("tensorflow",), first_seed=7, processes=2)
    assert sorted(calls) == sorted([[spec.key for spec in specs[0::2]], [spec.key for spec in specs[1::2]]])
    assert set(together["outputs"]) == {f"{spec.key}|tensorflow" for spec in specs}
    assert set(together["cpu_s"]) == {spec.key for spec in specs}
    alone = run_proof(specs, frames, runtimes=("tensorflow",), first_seed=7)
    assert calls[-1] == [spec.key for spec in specs]
    for spec in specs:
        np.testing.assert_array_equal(together["expected"][spec.key], alone["expected"][spec.key])


def test_the_bench_command_hands_processes_to_each_group(monkeypatch):
    from click.testing import CliRunner

    from tests.model_io import tf_proof

    seen = []

    def fake_proof(specs, frames, first_seed=0, processes=1):
        seen.append((len(specs), first_seed, processes))
        keys = [spec.key for spec in specs]
        return {
            "expected": {key: np.zeros((1, 2), np.float32) for key in keys},
            "outputs": {f"{key}|{runtime}": np.zeros((1, 2), np.float32) for key in keys for runtime in RUNTIMES},
            "cpu_s": {key: {} for key in keys},
            "runtimes": list(RUNTIMES),
        }

    monkeypatch.setattr(tf_proof, "render_frames", lambda count: {})
    monkeypatch.setattr(tf_proof, "run_proof", fake_proof)
    arguments = ["--algorithm", "sac", "--match", "SHALLOW", "--models-per-process", "5", "--processes", "2"]
    result = CliRunner().invoke(tf_proof.tf_proof_command, arguments)
    assert result.exit_code == 0, result.output
    assert seen == [(5, 0, 2), (3, 5, 2)]
