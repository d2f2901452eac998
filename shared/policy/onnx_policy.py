"""Acting with a checkpoint's ONNX inference model (ONNX Runtime, one CPU thread).

A rollout worker chooses one action per frame; for one 120x160 frame the shallow network's PyTorch call is
dominated by framework overhead, which ONNX Runtime mostly avoids (the README's benchmarks give the figures).
Action choice itself is `networks.select_action`, so
sampling, argmax and e-greedy behave exactly as `ActorCritic.act`.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np
import onnxruntime
import torch

from racer.shared.policy.networks import CategoricalPolicy, GaussianPolicy, PolicyConfig, select_action


class OnnxPolicy:
    def __init__(self, onnx_bytes: bytes, config: PolicyConfig, log_std: torch.Tensor | None = None):
        """`log_std` (continuous policies): the network's clipped log-std parameter, shape (2,)."""
        options = onnxruntime.SessionOptions()
        options.intra_op_num_threads = 1
        options.inter_op_num_threads = 1
        options.graph_optimization_level = onnxruntime.GraphOptimizationLevel.ORT_ENABLE_ALL
        self._session = onnxruntime.InferenceSession(onnx_bytes, options, providers=["CPUExecutionProvider"])
        self.config = config
        self._inputs = {spec.name: spec.shape for spec in config.inputs}
        self._continuous = config.is_continuous
        if self._continuous and log_std is None:
            raise ValueError("a continuous policy needs the network's log_std")
        self._log_std = None if log_std is None else torch.as_tensor(log_std, dtype=torch.float32).detach().clone()

    def eval(self) -> OnnxPolicy:
        """For symmetry with ActorCritic (an inference session has no training mode)."""
        return self

    def policy_output(self, observation: Mapping[str, np.ndarray]) -> np.ndarray:
        """Action probabilities (discrete) or the Gaussian mean (continuous, DeepRacer's linear head), shape (num_actions,)."""
        feed = {}
        for name, shape in self._inputs.items():
            array = np.asarray(observation[name])
            if tuple(array.shape) != shape:
                raise ValueError(f"observation {name!r} has shape {array.shape}, the model expects {shape}")
            feed[name] = array[None].astype(np.float32)
        (output,) = self._session.run(None, feed)
        return output[0]

    def act(
        self,
        observation: Mapping[str, np.ndarray],
        greedy: bool,
        generator: np.random.Generator | None = None,
        epsilon: float = 0.0,
    ) -> tuple[int | np.ndarray, float]:
        output = torch.from_numpy(self.policy_output(observation)[None])
        if self._continuous:
            distribution = GaussianPolicy(mean=output, log_std=self._log_std)
        else:
            distribution = CategoricalPolicy(probs=output)
        return select_action(distribution, greedy, generator, epsilon)


class SacOnnxPolicy:
    """A SAC model's exported policy: greedy drives tanh(mean) (the `policy` output, as evaluation and the car do);
    training samples a = tanh(mean + std * N(0, 1)) from the `policy_mean` and `policy_log_std` outputs."""

    def __init__(self, onnx_bytes: bytes, config: PolicyConfig):
        options = onnxruntime.SessionOptions()
        options.intra_op_num_threads = 1
        options.inter_op_num_threads = 1
        options.graph_optimization_level = onnxruntime.GraphOptimizationLevel.ORT_ENABLE_ALL
        self._session = onnxruntime.InferenceSession(onnx_bytes, options, providers=["CPUExecutionProvider"])
        self.config = config
        self._inputs = {spec.name: spec.shape for spec in config.inputs}

    def eval(self) -> SacOnnxPolicy:
        return self

    def _outputs(self, observation: Mapping[str, np.ndarray]) -> list[np.ndarray]:
        feed = {}
        for name, shape in self._inputs.items():
            array = np.asarray(observation[name])
            if tuple(array.shape) != shape:
                raise ValueError(f"observation {name!r} has shape {array.shape}, the model expects {shape}")
            feed[name] = array[None].astype(np.float32)
        return self._session.run(None, feed)

    def policy_output(self, observation: Mapping[str, np.ndarray]) -> np.ndarray:
        """The deterministic action tanh(mean) in [-1, 1], shape (2,)."""
        return self._outputs(observation)[0][0]

    def act(
        self,
        observation: Mapping[str, np.ndarray],
        greedy: bool,
        generator: np.random.Generator | None = None,
        epsilon: float = 0.0,
    ) -> tuple[np.ndarray, float]:
        from racer.shared.policy.sac_networks import squashed_gaussian_log_prob

        if epsilon > 0.0:
            raise ValueError("e-greedy exploration is for discrete action spaces; SAC samples its squashed Gaussian")
        deterministic, mean, log_std = (output[0].astype(np.float64) for output in self._outputs(observation))
        if greedy:
            return deterministic.astype(np.float32), 0.0
        rng = generator if generator is not None else np.random.default_rng()
        raw = mean + np.exp(log_std) * rng.standard_normal(mean.shape)
        action = np.tanh(raw)
        log_prob = squashed_gaussian_log_prob(*(torch.from_numpy(a) for a in (raw, action, mean, log_std)))
        return action.astype(np.float32), float(log_prob)
