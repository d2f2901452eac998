"""The TensorFlow proof for networks beyond DeepRacer's three: the examples of docs/custom-networks.md (a wider
middleware; an extra conv layer with batch-norm) and a two-frame stack of the shallow network, discrete and
continuous, on DeepRacer's own Gazebo frames.

Why these: they exercise what the built-in networks never do in the frozen graph: dense layers of other sizes,
inference-mode batch-norm (given running statistics far from 0 and 1 here, so a dropped or misplaced batch-norm
shows), dropout left out at inference, and a camera input of two channels that is not stereo. The Gazebo frames are
one real episode's consecutive camera frames, so the stacked model sees real motion between its two frames.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import torch

from racer.shared.deepracer.model_metadata import parse_model_metadata
from racer.shared.policy.frame_stack import stack_episode_frames
from racer.shared.policy.network_file import parse_network_file
from racer.shared.policy.networks import ActorCritic, policy_config_from_metadata
from tests.shared_data import SHARED_DATA

__all__ = ["EXAMPLE_NETWORKS", "GAZEBO_FRAMES", "ExampleSpec", "example_frames", "example_specs", "make_example"]

_SHALLOW_CONVS = [
    {"type": "Conv2d", "num_filters": 32, "kernel_size": 8, "strides": 4},
    {"type": "Conv2d", "num_filters": 64, "kernel_size": 4, "strides": 2},
    {"type": "Conv2d", "num_filters": 64, "kernel_size": 3, "strides": 1},
]
EXAMPLE_NETWORKS: dict[str, dict] = {
    "WIDE_MIDDLEWARE": {
        "name": "WIDE_MIDDLEWARE",
        "input_embedders": {"FRONT_FACING_CAMERA": _SHALLOW_CONVS},
        "middleware": [{"type": "Dense", "units": 1024}, {"type": "Dense", "units": 256}],
    },
    "EXTRA_CONV_BATCHNORM": {
        "name": "EXTRA_CONV_BATCHNORM",
        "input_embedders": {
            "FRONT_FACING_CAMERA": [
                *({**layer, "batchnorm": True} for layer in _SHALLOW_CONVS),
                {"type": "Conv2d", "num_filters": 64, "kernel_size": 3, "strides": 1},
            ]
        },
        "middleware": [{"type": "Dense", "units": 512, "dropout": 0.1}],
    },
}
"""docs/custom-networks.md's two network files, as written there (a test keeps them equal)."""
GAZEBO_FRAMES = SHARED_DATA / "frames" / "gazebo_reinvent_episode"
"""DeepRacer's Gazebo front camera over one re:Invent 2018 episode, beside the racer checkout."""
SENSOR = "FRONT_FACING_CAMERA"


def proof_action_space(continuous: bool) -> object:
    """The proof models' action space: steering ±30° and 0.5-3 m/s, or 5 angles at 1 and 2 m/s (10 actions)."""
    if continuous:
        return {"steering_angle": {"low": -30, "high": 30}, "speed": {"low": 0.5, "high": 3}}
    return [{"steering_angle": angle, "speed": speed} for angle in (-30, -15, 0, 15, 30) for speed in (1, 2)]


@dataclass(frozen=True)
class ExampleSpec:
    neural_network: str
    continuous: bool
    stack_size: int = 1

    @property
    def key(self) -> str:
        """NETWORK:SENSOR[*N]:discrete|continuous, as tf_proof's keys (summarize reads the kind at the end)."""
        frames = f"*{self.stack_size}" if self.stack_size > 1 else ""
        return f"{self.neural_network}:{SENSOR}{frames}:{'continuous' if self.continuous else 'discrete'}"

    def metadata(self) -> dict:
        return {
            "action_space": proof_action_space(self.continuous),
            "sensor": [SENSOR],
            "neural_network": self.neural_network,
            "action_space_type": "continuous" if self.continuous else "discrete",
            "version": "5",
        }


def example_specs() -> list[ExampleSpec]:
    """The three examples, discrete and continuous: 6 models."""
    return [
        ExampleSpec(network, continuous, stack_size)
        for network, stack_size in (
            ("WIDE_MIDDLEWARE", 1),
            ("EXTRA_CONV_BATCHNORM", 1),
            ("DEEP_CONVOLUTIONAL_NETWORK_SHALLOW", 2),
        )
        for continuous in (False, True)
    ]


def make_example(spec: ExampleSpec, seed: int) -> ActorCritic:
    """The example's network with weights like a trained one's: a wider policy head (as tf_proof.make_model), and
    batch-norm as training leaves it: running statistics of the real frames (means far from 0, variances far from
    1, so a dropped or misplaced batch-norm shows) and scales and shifts away from 1 and 0. Fresh running statistics
    (0 and 1) would leave every frame's features nearly alike, and the discrete policy would pick one action for
    all: the fp16 greedy comparison would then prove nothing."""
    torch.manual_seed(seed)
    metadata = parse_model_metadata(spec.metadata(), spec.key)
    network_file = EXAMPLE_NETWORKS.get(spec.neural_network)
    parsed = parse_network_file(network_file, spec.neural_network) if network_file else None
    model = ActorCritic(policy_config_from_metadata(metadata, parsed, spec.stack_size))
    norms = [module for module in model.modules() if isinstance(module, torch.nn.BatchNorm1d | torch.nn.BatchNorm2d)]
    with torch.no_grad():
        model.policy_head.weight.normal_(0.0, 0.05)
        for module in norms:
            module.weight.uniform_(0.5, 1.5)
            module.bias.uniform_(-0.3, 0.3)
        if norms:
            _running_statistics_of_frames(model, norms, example_frames(spec.stack_size))
    return model.eval()


def _running_statistics_of_frames(model: ActorCritic, norms: list, frames: dict[str, np.ndarray]) -> None:
    """Each batch-norm's running mean and variance over `frames` (a cumulative average over one pass, layer after
    layer as training's forward passes compute them)."""
    for module in norms:
        module.reset_running_stats()
        module.momentum = None  # the cumulative average: one pass gives the frames' own statistics
    model.train()
    observations = {name: torch.from_numpy(value) for name, value in frames.items()}
    model.policy_output(observations)
    model.value(observations)
    for module in norms:
        module.momentum = 0.1  # torch's default, what racer trains with


def example_frames(stack_size: int, folder: Path = GAZEBO_FRAMES) -> dict[str, np.ndarray]:
    """The Gazebo episode's frames as the camera input (N, 120, 160, stack_size) float32, in episode order, each
    stacked with the frames before it as the workers stack them."""
    from racer.model_io.explain_inputs import load_frames  # PIL: only when the proof runs

    if not folder.is_dir():
        raise FileNotFoundError(f"{folder}: DeepRacer's Gazebo frames are not there (shared/deepracer-data)")
    _, grey = load_frames((folder,))
    stacked = stack_episode_frames(grey[..., None], stack_size)
    return {SENSOR: stacked.astype(np.float32)}
