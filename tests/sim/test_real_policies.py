"""Closed loop with real DeepRacer policies: the sample model trained in DeepRacer's Gazebo on re:Invent 2018
(`models/gazebo-sample-reinvent2018`, frozen graphs, 12 actions, front camera) drives racer's `2019` generation (the
simulator it was trained in) greedily.

`python -m benchmarks transfer` drives them from 10 spread starts (docs/transfer.md); here three starts each keep the test at a few seconds. The graphs' weights are read
from the GraphDef's Const nodes in numpy (no TensorFlow), the network is DeepRacer's shallow one.
"""

from __future__ import annotations

import json

import numpy as np
import pytest

from racer.shared.deepracer.model_metadata import parse_model_metadata
from racer.shared.sim.car.dynamics import SIMTRACE_FIT_DYNAMICS
from racer.shared.sim.config import EnvConfig
from racer.shared.sim.env import DeepRacerEnv

NETWORK = "main_level/agent/main/online/network_1/"

pytestmark = pytest.mark.slow  # seconds to minutes each: the full suite runs them, the fast loop does not


def _varint(buffer: bytes, i: int) -> tuple[int, int]:
    value = shift = 0
    while True:
        byte = buffer[i]
        i += 1
        value |= (byte & 0x7F) << shift
        shift += 7
        if not byte & 0x80:
            return value, i


def _fields(buffer: bytes):
    """(field number, value) of a protobuf message: ints for varints, bytes otherwise."""
    i = 0
    while i < len(buffer):
        tag, i = _varint(buffer, i)
        number, wire = tag >> 3, tag & 7
        if wire == 0:
            value, i = _varint(buffer, i)
        elif wire == 2:
            size, i = _varint(buffer, i)
            value, i = buffer[i : i + size], i + size
        elif wire == 5:
            value, i = buffer[i : i + 4], i + 4
        elif wire == 1:
            value, i = buffer[i : i + 8], i + 8
        else:
            raise ValueError(f"protobuf wire type {wire}")
        yield number, value


def frozen_graph_weights(path) -> dict[str, np.ndarray]:
    """Float Const tensors of a frozen GraphDef by node name (NodeDef: 1 name, 2 op, 5 attr; TensorProto: 2 shape,
    4 tensor_content)."""
    weights = {}
    for number, node in _fields(path.read_bytes()):
        if number != 1:
            continue
        name = op = None
        attrs = {}
        for key, value in _fields(node):
            if key == 1:
                name = value.decode()
            elif key == 2:
                op = value.decode()
            elif key == 5:
                entry = dict(_fields(value))
                attrs[entry.get(1, b"").decode()] = entry.get(2, b"")
        if op == "Const" and "value" in attrs:
            tensor = dict(_fields(dict(_fields(attrs["value"])).get(8, b"")))
            if tensor.get(4):
                shape = [dict(_fields(dim)).get(1, 0) for key, dim in _fields(tensor.get(2, b"")) if key == 2]
                weights[name] = np.frombuffer(tensor[4], "<f4").reshape(shape)
    return weights


def _conv_relu(x: np.ndarray, kernel: np.ndarray, bias: np.ndarray, stride: int) -> np.ndarray:
    kh, kw, _, out = kernel.shape
    h, w = (x.shape[0] - kh) // stride + 1, (x.shape[1] - kw) // stride + 1
    windows = np.lib.stride_tricks.sliding_window_view(x, (kh, kw), axis=(0, 1))[::stride, ::stride][:h, :w]
    return np.maximum(windows.transpose(0, 1, 3, 4, 2).reshape(h, w, -1) @ kernel.reshape(-1, out) + bias, 0)


def greedy_action(weights: dict[str, np.ndarray], grey: np.ndarray) -> int:
    x = grey[..., None].astype(np.float32) / 255.0
    for index, stride in ((0, 4), (2, 2), (4, 1)):
        layer = f"{NETWORK}FRONT_FACING_CAMERA/Conv2d_{index}/"
        x = _conv_relu(x, weights[layer + "kernel"], weights[layer + "bias"], stride)
    dense = NETWORK + "middleware_fc_embedder/Dense_0/"
    hidden = np.maximum(x.reshape(-1) @ weights[dense + "kernel"] + weights[dense + "bias"], 0)
    head = NETWORK + "ppo_head_0/policy_fc/"
    return int(np.argmax(hidden @ weights[head + "kernel"] + weights[head + "bias"]))


def laps(deepracer_data, checkpoint: int, starts: tuple[float, ...], **config) -> list[float]:
    """Progress (%) of one greedy evaluation episode from each start on reinvent_base, base world."""
    folder = deepracer_data / "models" / "gazebo-sample-reinvent2018"
    metadata = parse_model_metadata(json.loads((folder / "model_metadata.json").read_text()), source="sample")
    weights = frozen_graph_weights(folder / f"model_{checkpoint}.pb")
    config = {"generation": "2019", **config}  # the simulator they were trained in (the landing rule's)
    env = DeepRacerEnv(
        EnvConfig(track=deepracer_data / "routes" / "reinvent_base.npy", model_metadata=metadata, **config)
    )
    key = next(iter(env.observation_space.spaces))
    progress = []
    try:
        for start in starts:
            obs, info = env.reset(seed=1, options={"evaluation": True, "start_ndist": start})
            done, steps = False, 0
            while not done and steps < 400:
                obs, _, terminated, truncated, info = env.step(greedy_action(weights, obs[key][..., 0]))
                done, steps = terminated or truncated, steps + 1
            progress.append(float(info["progress"]))
    finally:
        env.close()
    return progress


STARTS = (0.0, 0.4, 0.7)


@pytest.mark.parametrize("checkpoint", [30, 15])
def test_gazebo_trained_policies_lap_in_the_2019_generation(deepracer_data, checkpoint):
    assert laps(deepracer_data, checkpoint, STARTS) == [100.0] * len(STARTS)


def test_the_simtrace_fit_car_loses_them(deepracer_data):
    """The open-loop fit's car (soft front axle, 6x the URDF's yaw inertia): model_30 leaves the road every time."""
    assert max(laps(deepracer_data, 30, STARTS, car_dynamics=SIMTRACE_FIT_DYNAMICS)) < 100.0


def test_with_dynamics_randomization_the_real_policy_still_drives(deepracer_data):
    """A few steps of model_30 on cars drawn around the default (training episodes: evaluation drives the profile's
    own car): the env runs and the car gets going."""
    folder = deepracer_data / "models" / "gazebo-sample-reinvent2018"
    metadata = parse_model_metadata(json.loads((folder / "model_metadata.json").read_text()), source="sample")
    weights = frozen_graph_weights(folder / "model_30.pb")
    env = DeepRacerEnv(
        EnvConfig(
            track=deepracer_data / "routes" / "reinvent_base.npy",
            model_metadata=metadata,
            dynamics_randomization=True,
            generation="2019",
        )
    )
    key = next(iter(env.observation_space.spaces))
    try:
        for seed in (0, 1, 2):
            obs, _ = env.reset(seed=seed)
            assert env.car_dynamics != env.config.car_dynamics
            for _ in range(20):
                obs, _, terminated, truncated, info = env.step(greedy_action(weights, obs[key][..., 0]))
                assert not truncated and np.isfinite(env.data.qpos).all()
                if terminated:
                    break
            assert info["progress"] > 0.0
    finally:
        env.close()
