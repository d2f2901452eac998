"""What the episode loop asks of a policy, for training, in-training evaluation and `racer evaluate` alike.

`ActorCritic` (torch), the ONNX policies of the workers (racer.shared.policy.onnx_policy) and scripted stand-ins in
tests all fit: one observation in, one action and its log-probability out. Several envs stepped together need
`act_batch` as well: one forward pass for all, row i the action `act` would give env i alone.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any, Protocol

import numpy as np


class Policy(Protocol):
    def act(
        self,
        observation: Mapping[str, np.ndarray],
        greedy: bool,
        generator: np.random.Generator | None = None,
        epsilon: float = 0.0,
    ) -> tuple[Any, float]: ...


class BatchPolicy(Policy, Protocol):
    def act_batch(
        self,
        observations: Sequence[Mapping[str, np.ndarray]],
        greedy: bool,
        generators: Sequence[np.random.Generator],
        epsilons: Sequence[float],
    ) -> list[tuple[Any, float]]: ...
