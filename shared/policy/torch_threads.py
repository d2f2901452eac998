"""One torch thread in a worker process, without importing torch there.

The rollout and evaluation workers act through ONNX Runtime (one-thread sessions, racer.shared.policy.onnx_policy) and
import no torch: their image has none. A torch network can still act in such a process (a test, a tool handing an
`ActorCritic` to an evaluation session); then torch is already imported, and a batch of one gains nothing from more
threads while other processes share the cores, so it gets one.
"""

from __future__ import annotations

import sys

__all__ = ["one_torch_thread_if_loaded"]


def one_torch_thread_if_loaded() -> None:
    """`torch.set_num_threads(1)` when this process has imported torch; nothing (and no import) otherwise."""
    torch = sys.modules.get("torch")
    if torch is not None:
        torch.set_num_threads(1)
