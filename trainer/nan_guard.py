"""Never abort on NaN: detect non-finite numbers during an update and return to the last good state.

DeepRacer stops the whole training job on a NaN loss. Here the PPO update checks its losses and gradients every
minibatch and the weights after every epoch; on the first non-finite value it raises `NonFiniteError`, and the
trainer restores the `LastGoodState` (the network and optimiser as they were before this update, i.e. the weights of
the last published checkpoint), halves the learning rate and tries again.

`LastGoodState` keeps an in-memory copy instead of re-reading the checkpoint from the store: it holds the same numbers,
works before checkpoint 0 is uploaded and does not depend on the store being reachable at that moment.
"""

from __future__ import annotations

import logging
import math
from collections.abc import Callable, Iterable, Sequence
from typing import TYPE_CHECKING, TypeVar

import numpy as np
import torch
from torch import nn

if TYPE_CHECKING:
    from racer.shared.episode import Episode

log = logging.getLogger(__name__)

__all__ = [
    "LastGoodState",
    "NanGuard",
    "NonFiniteError",
    "check_finite",
    "finite_episodes",
    "first_non_finite_parameter",
    "gradient_norm",
]

T = TypeVar("T")


class NonFiniteError(ArithmeticError):
    """A loss, gradient or weight became NaN or infinite; `what` says which, for the log line."""

    def __init__(self, what: str):
        super().__init__(what)
        self.what = what


def check_finite(value: float, what: str) -> None:
    if not math.isfinite(value):
        raise NonFiniteError(f"{what} is {value}")


def gradient_norm(parameters: Iterable[nn.Parameter]) -> float:
    """L2 norm over all gradients (non-finite if any gradient element is); one fused pass, no clipping."""
    grads = [p.grad for p in parameters if p.grad is not None]
    if not grads:
        return 0.0
    return float(torch.nn.utils.get_total_norm(grads, norm_type=2.0))


def first_non_finite_parameter(network: nn.Module) -> str | None:
    """Name of the first parameter holding a NaN or infinity, or None when all weights are finite.

    The update asks this after every epoch, so it takes one fused L2 norm over all weights (one pass, no
    per-element mask) rather than an element-wise isfinite scan. The norm is finite exactly when every weight is, except when finite
    weights overflow its sum of squares: only a non-finite norm leads to the scan, which names the parameter (or
    finds none)."""
    weights = [parameter.detach() for parameter in network.parameters()]
    if not weights or math.isfinite(float(torch.nn.utils.get_total_norm(weights, norm_type=2.0))):
        return None
    for name, parameter in network.named_parameters():
        if not bool(torch.isfinite(parameter).all()):
            return name
    return None


def _clone(value):
    if isinstance(value, torch.Tensor):
        return value.detach().clone(memory_format=torch.preserve_format)
    if isinstance(value, dict):
        return {key: _clone(item) for key, item in value.items()}
    if isinstance(value, list):
        return [_clone(item) for item in value]
    return value


class LastGoodState:
    """A copy of a network's weights and its optimiser's state, taken when both were known to be finite."""

    def __init__(self, network: nn.Module, optimizer: torch.optim.Optimizer):
        self.network = network
        self.optimizer = optimizer
        self._weights: dict[str, torch.Tensor] = {}
        self._optimizer_state: dict = {}
        self.capture()

    def capture(self) -> None:
        name = first_non_finite_parameter(self.network)
        if name is not None:
            raise NonFiniteError(f"weight {name} is not finite; refusing to keep it as the last good state")
        self._weights = _clone(self.network.state_dict())
        self._optimizer_state = _clone(self.optimizer.state_dict())

    def restore(self) -> None:
        """Put the saved weights and optimiser moments back; the learning rate is left to the caller."""
        learning_rates = [group["lr"] for group in self.optimizer.param_groups]
        self.network.load_state_dict(self._weights)
        self.optimizer.load_state_dict(_clone(self._optimizer_state))
        for group, learning_rate in zip(self.optimizer.param_groups, learning_rates, strict=True):
            group["lr"] = learning_rate


def roll_back(last_good: LastGoodState, learning_rate: float, reason: str) -> float:
    """Restore the weights and optimiser from before the update and return the halved learning rate."""
    last_good.restore()
    log.warning(
        "NaN guard: %s; rolled back to the weights before this update and halved the learning rate %g -> %g",
        reason,
        learning_rate,
        learning_rate / 2,
    )
    return learning_rate / 2


def finite_episodes(episodes: Sequence[Episode]) -> list[Episode]:
    """Drop (and log) episodes carrying NaN/inf in rewards, float observations or actions: they would poison GAE."""
    kept = []
    for episode in episodes:
        arrays = [episode.rewards, episode.actions, *episode.observations.values()]
        bad = [a for a in arrays if np.issubdtype(a.dtype, np.floating) and not np.all(np.isfinite(a))]
        if bad:
            log.warning(
                "NaN guard: dropped episode %d of worker %d (world %s): it contains NaN or infinite values",
                episode.episode_index,
                episode.worker_id,
                episode.world,
            )
            continue
        kept.append(episode)
    return kept


class NanGuard:
    """The rollback-and-halve retry of one learner's updates: up to `max_retries` retries, then the data is skipped."""

    def __init__(self, network: nn.Module, optimizer: torch.optim.Optimizer, max_retries: int):
        self.network = network
        self.optimizer = optimizer
        self.max_retries = max_retries
        self.last_good = LastGoodState(network, optimizer)
        self.rollbacks = 0
        """How many times an update was rolled back because of a non-finite number (for logs and tests)."""

    @property
    def learning_rate(self) -> float:
        return float(self.optimizer.param_groups[0]["lr"])

    def run(self, train: Callable[[], T], skipped: str) -> T | None:
        """`train()` from the last good state until it returns without a non-finite number; None (after logging that
        `skipped`, e.g. "80 transitions", was skipped) when every attempt failed."""
        if first_non_finite_parameter(self.network) is not None:  # changed behind our back: start from the last good
            self._roll_back("weights were not finite at the start of the update")
        self.last_good.capture()
        for attempt in range(1, self.max_retries + 2):
            try:
                return train()
            except NonFiniteError as error:
                self._roll_back(f"{error.what} (attempt {attempt} of {self.max_retries + 1})")
        log.warning(
            "NaN guard: skipped this iteration's %s; training continues from the last good "
            "weights with learning rate %g",
            skipped,
            self.learning_rate,
        )
        return None

    def _roll_back(self, reason: str) -> None:
        halved = roll_back(self.last_good, self.learning_rate, reason)
        for group in self.optimizer.param_groups:
            group["lr"] = halved
        self.rollbacks += 1
