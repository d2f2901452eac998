"""The TensorFlow proof's verdict (tf_proof.summarize): fp32 within 1e-5, fp16 within 1e-3 or two fp16 steps at the output's size."""

from __future__ import annotations

import numpy as np

from tests.model_io.tf_proof import RUNTIMES, summarize


def _proof(expected: np.ndarray, fp16_error: float) -> dict:
    """One continuous model whose every runtime is exact except the fp16 ones, off by `fp16_error`."""
    outputs = {
        f"m_continuous|{runtime}": expected + (fp16_error if runtime.endswith("fp16") else 0.0) for runtime in RUNTIMES
    }
    return {"expected": {"m_continuous": expected}, "outputs": outputs, "runtimes": RUNTIMES, "cpu_s": {}}


def test_fp16_is_judged_against_the_outputs_scale():
    large = np.full((4, 2), 1.35)
    assert summarize(_proof(large, 1.8e-3))["goals_met"]  # fp16 steps are 9.8e-4 between 1 and 2
    assert not summarize(_proof(large, 2.5e-3))["goals_met"]
    small = np.full((4, 2), 0.1)
    assert summarize(_proof(small, 9e-4))["goals_met"]  # below 1 the scale is 1: the absolute rule
    assert not summarize(_proof(small, 1.2e-3))["goals_met"]
    figures = summarize(_proof(large, 1.8e-3))["openvino_fp16"]
    assert figures["max_abs_diff"] > 1e-3 and 0.9 < figures["max_diff_of_fp16_tolerance"] < 1.0
