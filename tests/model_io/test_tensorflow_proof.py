"""One function everywhere: racer's policy, the exported TensorFlow frozen graph, and the OpenVINO IR and LiteRT
(TFLite) models the cars make from it compute the same outputs on frames rendered by racer's simulator.

Every network (shallow, deep, deeper), every sensor combination DRoA's model validation accepts (a front camera or
stereo cameras, each alone or with LIDAR, SECTOR_LIDAR or DISCRETIZED_SECTOR_LIDAR: the SimApp's
`validation_worker.get_transition_data`), discrete and continuous: 48 models. All TensorFlow, OpenVINO and LiteRT
work runs in two processes (export, then run), never in this process, which has rendered with Mesa.

Also: TensorFlow imports the real DeepRacer checkpoint's `.meta` graph and restores a checkpoint racer wrote for the
same model_metadata.json (9 actions, shallow, front camera) with its own saver, and its policy equals racer's.
"""

from __future__ import annotations

import json
import tempfile
from pathlib import Path

import numpy as np
import pytest
import torch
from racer.shared.deepracer.model_metadata import NEURAL_NETWORKS, parse_model_metadata
from racer.shared.policy.networks import ActorCritic, build_actor_critic
from racer.shared.sim.config import EnvConfig
from racer.shared.sim.env import DeepRacerEnv
from safetensors.numpy import save_file

from racer.model_io.tensorflow.coach_layout import (
    POLICY_NETWORK,
    POLICY_OUTPUT_NODE,
    coach_tensors_from_racer,
    coach_variables,
    graph_spec,
    input_node,
)
from racer.model_io.tensorflow.convert import ExportJob, tensorflow_files
from racer.model_io.tensorflow.runner import run_tool

pytestmark = pytest.mark.slow

DATA = Path(__file__).resolve().parents[2].parent / "shared" / "deepracer-data"
REAL_CHECKPOINT = DATA / "checkpoints" / "reInvent2019-TestModel" / "model"
FRAMES = 100
SENSOR_SETS = [(camera, *lidar) for camera in ("FRONT_FACING_CAMERA", "STEREO_CAMERAS")
               for lidar in ((), ("LIDAR",), ("SECTOR_LIDAR",), ("DISCRETIZED_SECTOR_LIDAR",))]
RUNTIMES = ["tensorflow", "openvino_fp32", "litert_fp32", "openvino_fp16", "litert_fp16"]
FP32_TOLERANCE = 1e-5
FP16_TOLERANCE = 1e-3


def metadata_dict(network: str, sensors: tuple[str, ...], continuous: bool) -> dict:
    if continuous:
        space = {"steering_angle": {"low": -30, "high": 30}, "speed": {"low": 0.5, "high": 3}}
    else:
        space = [{"steering_angle": steering, "speed": speed} for steering in (-30, -15, 0, 15, 30) for speed in (1, 2)]
    return {"action_space": space, "sensor": list(sensors), "neural_network": network,
            "action_space_type": "continuous" if continuous else "discrete", "training_algorithm": "clipped_ppo",
            "version": "5", "lidar_config": {"num_sectors": 8, "num_values_per_sector": 4, "clipping_dist": 2.0}}


@pytest.fixture(scope="module")
def frames() -> dict[str, np.ndarray]:
    """FRAMES observations per sensor, rendered while driving with random actions (reset when an episode ends)."""
    rendered: dict[str, list[np.ndarray]] = {}
    for sensors in (("FRONT_FACING_CAMERA", "LIDAR"), ("STEREO_CAMERAS", "SECTOR_LIDAR"),
                    ("FRONT_FACING_CAMERA", "DISCRETIZED_SECTOR_LIDAR")):
        metadata = parse_model_metadata(metadata_dict(NEURAL_NETWORKS[0], sensors, False), "test metadata")
        env = DeepRacerEnv(EnvConfig(model_metadata=metadata), wall_clock=lambda: 1700000000.0)
        try:
            rng = np.random.default_rng(len(rendered))
            observation, _ = env.reset(seed=3)
            wanted = [sensor for sensor in sensors if sensor not in rendered]
            collected: dict[str, list[np.ndarray]] = {sensor: [] for sensor in wanted}
            while len(collected[wanted[0]]) < FRAMES:
                for sensor in wanted:
                    collected[sensor].append(np.asarray(observation[sensor]).copy())
                observation, _, terminated, truncated, _ = env.step(int(rng.integers(metadata.num_actions)))
                if terminated or truncated:
                    observation, _ = env.reset()
            rendered.update(collected)
        finally:
            env.close()
    return {sensor: np.stack(values).astype(np.float32) for sensor, values in rendered.items()}


def model_keys() -> list[tuple[str, tuple[str, ...], bool]]:
    return [(network, sensors, continuous) for network in NEURAL_NETWORKS for sensors in SENSOR_SETS
            for continuous in (False, True)]


def make_model(index: int, network: str, sensors: tuple[str, ...], continuous: bool) -> tuple[str, ActorCritic]:
    key = f"{network}:{'+'.join(sensors)}:{'continuous' if continuous else 'discrete'}"
    torch.manual_seed(index)
    model = build_actor_critic(parse_model_metadata(metadata_dict(network, sensors, continuous), key))
    if continuous:  # RL Coach's 0.01-scaled initialisation makes near-zero means: use a trained-like head
        with torch.no_grad():
            model.policy_head.weight.normal_(0.0, 0.05)
    return key, model.eval()


@pytest.fixture(scope="module")
def proof(frames) -> dict:
    """racer's outputs and every runtime's outputs for the 48 models. racer writes each model's weights (RL Coach's
    names) to a file of its own and forgets the model (the stereo DEEP networks are 230 MB each); one TensorFlow
    process then freezes and runs them one by one."""
    keys, expected, requests = [], {}, []
    with tempfile.TemporaryDirectory(prefix="racer-proof-") as folder:
        for index, spec in enumerate(model_keys()):
            key, model = make_model(index, *spec)
            feeds = {name: torch.from_numpy(frames[name]) for name in model.input_names}
            with torch.inference_mode():
                expected[key] = model.policy_output(feeds).numpy()
            weights = coach_tensors_from_racer(model.config, {name: value.numpy() for name, value
                                                              in model.state_dict().items()})
            path = Path(folder) / f"{index}.safetensors"
            save_file({name: value for name, value in weights.items() if name.startswith(POLICY_NETWORK)}, str(path))
            requests.append({"key": key, "graph": graph_spec(model.config), "weights_path": str(path)})
            keys.append(key)
            del model, weights
        _, outputs = run_tool("prove", {"models": requests, "runtimes": RUNTIMES},
                              {input_node(name): value for name, value in frames.items()})
    return {"keys": keys, "expected": expected, "outputs": outputs}


def test_every_network_sensor_set_and_action_space_is_covered(proof):
    assert len(proof["keys"]) == len(set(proof["keys"])) == 3 * 8 * 2
    assert {key.split(":")[0] for key in proof["keys"]} == set(NEURAL_NETWORKS)


@pytest.mark.parametrize("runtime", ["tensorflow", "openvino_fp32", "litert_fp32"])
def test_fp32_runtimes_agree_with_racer_to_1e5(proof, runtime):
    worst = {}
    for key, expected in proof["expected"].items():
        got = proof["outputs"][f"{key}|{runtime}"]
        assert got.shape == expected.shape, key
        worst[key] = float(np.abs(got - expected).max())
    bad = {key: value for key, value in worst.items() if value > FP32_TOLERANCE}
    assert not bad, f"{runtime}: outputs differ from racer's by more than {FP32_TOLERANCE}: {bad}"


@pytest.mark.parametrize("runtime", ["openvino_fp16", "litert_fp16"])
def test_fp16_conversions_pick_the_same_action_and_agree_to_1e3(proof, runtime):
    for key, expected in proof["expected"].items():
        got = proof["outputs"][f"{key}|{runtime}"]
        assert float(np.abs(got - expected).max()) <= FP16_TOLERANCE, key
        if key.endswith("discrete"):
            same = float(np.mean(got.argmax(axis=1) == expected.argmax(axis=1)))
            assert same >= 0.99, f"{runtime} {key}: same greedy action on {same:.0%} of frames"


def test_the_frames_are_real_and_the_policies_are_not_constant(frames, proof):
    """The comparison means something: frames differ, and discrete policies choose different actions."""
    front = frames["FRONT_FACING_CAMERA"]
    assert front.shape == (FRAMES, 120, 160, 1) and frames["STEREO_CAMERAS"].shape == (FRAMES, 120, 160, 2)
    assert len({frame.tobytes() for frame in front}) > FRAMES // 2
    assert 20 < float(front.mean()) < 235
    varied = [key for key, value in proof["expected"].items() if key.endswith("discrete")
              and len(set(value.argmax(axis=1).tolist())) > 1]
    assert len(varied) >= 12, varied


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
    result, tensors = run_tool("restore_meta", {
        "meta_path": str(REAL_CHECKPOINT / "11_Step-38428.ckpt.meta"),
        "checkpoint_prefix": str(tmp_path / "11_Step-38428.ckpt"),
        "inputs": [input_node("FRONT_FACING_CAMERA")], "output": POLICY_OUTPUT_NODE,
    }, {input_node("FRONT_FACING_CAMERA"): camera})
    assert result == {"missing": [], "mismatched": [], "restored": True}
    with torch.inference_mode():
        expected = network.policy_output({"FRONT_FACING_CAMERA": torch.from_numpy(camera)}).numpy()
    assert float(np.abs(tensors["policy"] - expected).max()) <= FP32_TOLERANCE


def test_racer_names_every_variable_of_the_real_checkpoint():
    """The 22 tensors of DeepRacer's checkpoint index, names and shapes, are what racer writes for that metadata."""
    metadata = parse_model_metadata(json.loads((REAL_CHECKPOINT / "model_metadata.json").read_text()), "real")
    result, _ = run_tool("read_checkpoint", {"checkpoint_prefix": str(REAL_CHECKPOINT / "11_Step-38428.ckpt"),
                                             "values": False})
    real = {name: tuple(item["shape"]) for name, item in result["variables"].items()}
    ours = {variable.name: variable.shape for variable in coach_variables(build_actor_critic(metadata).config)}
    assert len(real) == 22
    assert ours == real
