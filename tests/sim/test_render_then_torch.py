"""Rendering with Mesa and then creating a torch optimiser must not crash the process (triton's LLVM vs Mesa's)."""

import subprocess
import sys

SCRIPT = """
from racer.shared.sim.env import DeepRacerEnv
env = DeepRacerEnv()
env.reset(seed=0)
env.step(0)
import torch
torch.optim.Adam([torch.nn.Parameter(torch.zeros(3))])
print("ok")
"""


def test_optimiser_after_rendering_in_one_process():
    result = subprocess.run([sys.executable, "-c", SCRIPT], capture_output=True, text=True, timeout=300)
    assert result.returncode == 0, result.stderr[-2000:]
    assert result.stdout.strip().endswith("ok")
