"""Where the trainer's networks and updates run: `--device auto|cpu|cuda`.

torch from PyPI is the CUDA build, so a machine with an NVIDIA GPU and its driver can train there with no other
install. Only the trainer moves: the rollout and evaluation workers act with ONNX Runtime on the CPU (its CUDA build
is a separate package), and checkpoints are written from CPU copies, so a model trained on a GPU is the same files as
one trained on the CPU. `cuda` on a machine without a usable GPU is refused before anything starts, with torch's own
reason; `auto` is then the CPU.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # torch loads only when a device is resolved: `racer train --help` stays fast
    import torch

__all__ = [
    "DEFAULT_DEVICE",
    "DEVICE_NAMES",
    "DeviceError",
    "cuda_absence_reason",
    "describe_device",
    "exact_fp32",
    "resolve_device",
]

DEVICE_NAMES: tuple[str, ...] = ("auto", "cpu", "cuda")
DEFAULT_DEVICE = "auto"


class DeviceError(ValueError):
    """`--device cuda` where torch finds no usable CUDA device."""


def cuda_absence_reason() -> str | None:
    """Why torch cannot use CUDA here, in words; None when it can."""
    import torch

    if torch.version.cuda is None:
        return f"this torch ({torch.__version__}) is a CPU-only build"
    if not torch.cuda.is_available():
        return (
            f"torch {torch.__version__} (CUDA {torch.version.cuda}) finds no CUDA device: no NVIDIA GPU, no driver, "
            "or CUDA_VISIBLE_DEVICES hides it"
        )
    return None


def resolve_device(name: str, absence_reason: Callable[[], str | None] = cuda_absence_reason) -> torch.device:
    """The torch device `--device NAME` means here: `auto` is the first CUDA device when there is one, else the CPU;
    `cuda` without one is a DeviceError that says why."""
    import torch

    if name not in DEVICE_NAMES:
        raise DeviceError(f"--device {name!r}: choose one of {', '.join(DEVICE_NAMES)}")
    if name == "cpu":
        return torch.device("cpu")
    reason = absence_reason()
    if reason is None:
        return torch.device("cuda")
    if name == "cuda":
        raise DeviceError(f"--device cuda: {reason}. Train on the CPU with --device cpu (or auto).")
    return torch.device("cpu")


def exact_fp32(device: torch.device) -> None:
    """On a CUDA device, fp32 convolutions and products in fp32, not TF32.

    cuDNN computes fp32 convolutions in TF32 (a 10-bit mantissa) by default on Ampere and newer GPUs, which would make
    `--precision fp32` mean something else on a GPU than on a CPU; bf16 is the trainer's reduced precision and is
    asked for by name. These are torch's process-wide switches, set once by the learner that owns the process's
    training."""
    import torch

    if device.type == "cuda":
        torch.backends.cudnn.allow_tf32 = False
        torch.backends.cuda.matmul.allow_tf32 = False


def describe_device(device: torch.device) -> str:
    """`cpu`, or `cuda (NVIDIA H100 80GB HBM3)`: what logs and benchmark lines print."""
    import torch

    if device.type == "cuda":
        return f"cuda ({torch.cuda.get_device_name(device)})"
    return device.type
