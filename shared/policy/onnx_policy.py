"""Acting with a checkpoint's ONNX inference model (ONNX Runtime, one CPU thread).

A rollout worker chooses one action per frame. ONNX Runtime's default graph optimisations (NCHWc convolutions) are
the fastest exact path measured on AVX2, ahead of the PyTorch module in either memory layout. In the shallow
network most of a small batch's call is the 11264x512 dense layer, which streams its 23 MB of weights from memory
once per call whatever the batch; so the cost per frame falls with the batch (`python -m benchmarks rollout`).
Action choice itself is numpy alone (racer.shared.policy.action_selection, which
`networks.select_action` runs too), so sampling, argmax and e-greedy behave exactly as `ActorCritic.act`, and this
module imports no torch: the rollout and evaluation workers' image carries none.

The exported graph (`model_<N>.onnx`) declares batch 1, as DeepRacer's car model does; its operators (Conv, Flatten,
Gemm, Softmax) do not depend on the batch, so the session is built from a copy whose batch dimension is declared
free. `act_batch` then picks the actions of several envs with one forward pass (cheaper per frame than one call per
env), and each row's output equals what a batch-1 call gives (tests/policy/test_onnx_policy.py).
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np
import onnx
import onnxruntime

from racer.shared.policy.action_selection import (
    select_discrete_action,
    select_gaussian_action,
    select_squashed_gaussian_action,
)
from racer.shared.policy.policy_config import PolicyConfig


def _free_batch(onnx_bytes: bytes) -> bytes:
    """The same graph with its inputs' and outputs' first dimension declared as a free `batch`."""
    model = onnx.load_from_string(onnx_bytes)
    for value in (*model.graph.input, *model.graph.output):
        value.type.tensor_type.shape.dim[0].dim_param = "batch"
    return model.SerializeToString()


def _session(onnx_bytes: bytes) -> onnxruntime.InferenceSession:
    options = onnxruntime.SessionOptions()
    options.intra_op_num_threads = 1
    options.inter_op_num_threads = 1
    options.graph_optimization_level = onnxruntime.GraphOptimizationLevel.ORT_ENABLE_ALL
    return onnxruntime.InferenceSession(_free_batch(onnx_bytes), options, providers=["CPUExecutionProvider"])


def _feed(inputs: Mapping[str, tuple[int, ...]], observations: Sequence[Mapping[str, np.ndarray]]) -> dict:
    feed = {}
    for name, shape in inputs.items():
        arrays = [np.asarray(observation[name]) for observation in observations]
        for array in arrays:
            if tuple(array.shape) != shape:
                raise ValueError(f"observation {name!r} has shape {array.shape}, the model expects {shape}")
        feed[name] = np.stack(arrays).astype(np.float32)
    return feed


class OnnxPolicy:
    def __init__(self, onnx_bytes: bytes, config: PolicyConfig, log_std: np.ndarray | None = None):
        """`log_std` (continuous policies): the network's clipped log-std parameter (float32), shape (2,)."""
        self._session = _session(onnx_bytes)
        self.config = config
        self._inputs = {spec.name: spec.shape for spec in config.inputs}
        self._continuous = config.is_continuous
        if self._continuous and log_std is None:
            raise ValueError("a continuous policy needs the network's log_std")
        self._log_std = None if log_std is None else np.array(log_std, dtype=np.float32).astype(np.float64)

    def eval(self) -> OnnxPolicy:
        """For symmetry with ActorCritic (an inference session has no training mode)."""
        return self

    def policy_outputs(self, observations: Sequence[Mapping[str, np.ndarray]]) -> np.ndarray:
        """One forward pass for several observations: shape (len(observations), num_actions)."""
        (output,) = self._session.run(None, _feed(self._inputs, observations))
        return output

    def policy_output(self, observation: Mapping[str, np.ndarray]) -> np.ndarray:
        """Action probabilities (discrete) or the Gaussian mean (continuous, DeepRacer's linear head), shape (num_actions,)."""
        return self.policy_outputs([observation])[0]

    def _select(self, output: np.ndarray, greedy: bool, generator, epsilon: float) -> tuple[int | np.ndarray, float]:
        rng = generator if generator is not None else np.random.default_rng()
        if not self._continuous:
            return select_discrete_action(output.astype(np.float64), greedy, rng, epsilon)
        return select_gaussian_action(output.astype(np.float64), self._log_std, greedy, rng, epsilon)

    def act(
        self,
        observation: Mapping[str, np.ndarray],
        greedy: bool,
        generator: np.random.Generator | None = None,
        epsilon: float = 0.0,
    ) -> tuple[int | np.ndarray, float]:
        return self._select(self.policy_output(observation), greedy, generator, epsilon)

    def act_batch(
        self,
        observations: Sequence[Mapping[str, np.ndarray]],
        greedy: bool,
        generators: Sequence[np.random.Generator],
        epsilons: Sequence[float],
    ) -> list[tuple[int | np.ndarray, float]]:
        """`act` for several envs with one forward pass; row i samples with `generators[i]` and `epsilons[i]`, so each
        env's actions are the ones `act` would give it alone."""
        outputs = self.policy_outputs(observations)
        return [
            self._select(output, greedy, generator, epsilon)
            for output, generator, epsilon in zip(outputs, generators, epsilons, strict=True)
        ]


class SacOnnxPolicy:
    """A SAC model's exported policy: greedy drives tanh(mean) (the `policy` output, as evaluation and the car do);
    training samples a = tanh(mean + std * N(0, 1)) from the `policy_mean` and `policy_log_std` outputs."""

    def __init__(self, onnx_bytes: bytes, config: PolicyConfig):
        self._session = _session(onnx_bytes)
        self.config = config
        self._inputs = {spec.name: spec.shape for spec in config.inputs}

    def eval(self) -> SacOnnxPolicy:
        return self

    def _outputs(self, observations: Sequence[Mapping[str, np.ndarray]]) -> list[np.ndarray]:
        return self._session.run(None, _feed(self._inputs, observations))

    def policy_output(self, observation: Mapping[str, np.ndarray]) -> np.ndarray:
        """The deterministic action tanh(mean) in [-1, 1], shape (2,)."""
        return self._outputs([observation])[0][0]

    def act(
        self,
        observation: Mapping[str, np.ndarray],
        greedy: bool,
        generator: np.random.Generator | None = None,
        epsilon: float = 0.0,
    ) -> tuple[np.ndarray, float]:
        return self.act_batch([observation], greedy, [generator], [epsilon])[0]

    def act_batch(
        self,
        observations: Sequence[Mapping[str, np.ndarray]],
        greedy: bool,
        generators: Sequence[np.random.Generator | None],
        epsilons: Sequence[float],
    ) -> list[tuple[np.ndarray, float]]:
        """`act` for several envs with one forward pass (row i samples with `generators[i]`)."""
        outputs = self._outputs(observations)
        return [
            self._act_row(*(output[i].astype(np.float64) for output in outputs), greedy, generator, epsilon)
            for i, (generator, epsilon) in enumerate(zip(generators, epsilons, strict=True))
        ]

    @staticmethod
    def _act_row(deterministic, mean, log_std, greedy: bool, generator, epsilon: float) -> tuple[np.ndarray, float]:
        rng = generator if generator is not None else np.random.default_rng()
        return select_squashed_gaussian_action(deterministic, mean, log_std, greedy, rng, epsilon)
