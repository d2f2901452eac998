"""Is a network small enough for the machine and the car? Build it once and measure: the parameter count and the
policy's forward pass on one observation on one core (racer.trainer.preflight refuses or warns before training)."""

from __future__ import annotations

import time
from dataclasses import dataclass

import torch

from racer.shared.policy.factory import build_network
from racer.shared.policy.network_file import NETWORK_FILE
from racer.shared.policy.networks import PolicyConfig

__all__ = ["MAX_FORWARD_S", "MAX_PARAMETERS", "WARN_PARAMETERS", "SizeFindings", "network_size_findings"]

MAX_FORWARD_S = 1.0 / 15.0
"""The car acts on 15 camera frames a second: a policy forward pass slower than this on one core is refused."""
WARN_PARAMETERS = 10_000_000
MAX_PARAMETERS = 100_000_000
"""Above this the network (twice, policy and value, plus Adam's two moments) no longer fits a small machine."""


@dataclass(frozen=True)
class SizeFindings:
    parameters: int
    forward_s: float
    """Fastest of a few policy forward passes on one observation, one thread."""
    errors: tuple[str, ...]
    warnings: tuple[str, ...]


def network_size_findings(config: PolicyConfig, source: str = NETWORK_FILE, repeats: int = 5) -> SizeFindings:
    """Build the network once and measure it: refused above MAX_PARAMETERS or MAX_FORWARD_S, warned above
    WARN_PARAMETERS."""
    threads = torch.get_num_threads()
    torch.set_num_threads(1)
    try:
        network = build_network(config).eval()
        parameters = sum(p.numel() for p in network.parameters())
        observation = {spec.name: torch.zeros((1, *spec.shape)) for spec in config.inputs}
        times = []
        with torch.inference_mode():
            for _ in range(repeats + 1):
                start = time.perf_counter()
                network.policy_tower(observation)
                times.append(time.perf_counter() - start)
        forward_s = min(times[1:])
    finally:
        torch.set_num_threads(threads)
    errors, warnings = [], []
    if parameters > MAX_PARAMETERS:
        errors.append(f"{source}: {parameters:,} parameters, more than racer trains ({MAX_PARAMETERS:,})")
    elif parameters > WARN_PARAMETERS:
        warnings.append(f"{source}: {parameters:,} parameters: large for the car ({WARN_PARAMETERS:,} and more)")
    if forward_s > MAX_FORWARD_S:
        errors.append(
            f"{source}: a policy forward pass takes {forward_s * 1000:.0f} ms on one core of this machine, slower "
            f"than the car's 15 frames a second ({MAX_FORWARD_S * 1000:.0f} ms); fix: fewer or smaller layers"
        )
    return SizeFindings(parameters, forward_s, tuple(errors), tuple(warnings))
