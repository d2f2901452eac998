"""The arithmetic precision of the trainer's towers: fp32 on every CPU unless the user asks for bf16.

A default that followed the CPU family (bf16 where AVX512-BF16 or AMX computes it natively) once made the same run
learn six times slower per env step on most rented CPUs (docs/benchmarks.md, "Precision"). Training results may not
depend on the machine, so fp32 is the default everywhere and bf16 is a switch (`racer train --precision bf16`,
`RACER_PRECISION` in compose's `.env`) whose name is written into every checkpoint's manifest.
"""

from __future__ import annotations

from enum import StrEnum
from typing import TYPE_CHECKING

if TYPE_CHECKING:  # the launchers read the names without loading torch
    import torch

__all__ = ["DEFAULT_PRECISION", "PRECISION_NAMES", "Precision"]


class Precision(StrEnum):
    """What the policy and value towers compute in during an update; heads, losses, GAE and Adam stay fp32."""

    FP32 = "fp32"
    BF16 = "bf16"

    @property
    def tower_dtype(self) -> torch.dtype | None:
        """The CPU autocast dtype of the towers (None: plain fp32, no autocast)."""
        import torch

        return torch.bfloat16 if self is Precision.BF16 else None


DEFAULT_PRECISION = Precision.FP32
PRECISION_NAMES = tuple(p.value for p in Precision)
