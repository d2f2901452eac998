"""Where the trainer's time between updates goes: wall seconds per part of an iteration (checkpoint files, ONNX export,
the store's writes, retention, Redis announcements, summaries), added up since the trainer started and written into
each iteration's summary (`trainer_parts_s`), so a bench can tell what "other" is made of.

A part is counted `on_path` when it runs while no episode can be collected (between the end of collecting and the
next announcement: in a strict run the workers wait for it), and `while_collecting` when it runs after an
announcement, while the workers play (racer.trainer.training_loop moves what it can there).
"""

from __future__ import annotations

import time
from collections.abc import Iterator
from contextlib import contextmanager

CHECKPOINT_FILES = "checkpoint_files"
"""Weights and optimiser tensors to safetensors bytes, the manifest and its hashes."""
ONNX_EXPORT = "onnx_export"
CHECKPOINT_WRITES = "checkpoint_store_writes"
"""The checkpoint's puts to the store (lock, files, manifest, pointer)."""
RETENTION = "retention"
"""Listing model/ and deleting checkpoints beyond the 4 newest and the best."""
ITERATIONS_LOG = "iterations_log_write"
"""The iteration's line appended to the store's iterations log."""
ANNOUNCEMENTS = "announcements"
"""Redis: announcing an iteration or the newest checkpoint, acknowledging episodes, the summary on its stream."""
SUMMARIES = "summaries"
"""The iteration's summary and DeepRacer's log lines."""
PARTS = (CHECKPOINT_FILES, ONNX_EXPORT, CHECKPOINT_WRITES, RETENTION, ITERATIONS_LOG, ANNOUNCEMENTS, SUMMARIES)
ON_PATH = "on_path"
WHILE_COLLECTING = "while_collecting"


class IterationParts:
    """Wall seconds per part, in two buckets: on the workers' path, or while the workers play."""

    def __init__(self) -> None:
        self._seconds: dict[str, dict[str, float]] = {ON_PATH: {}, WHILE_COLLECTING: {}}
        self._bucket = ON_PATH

    @contextmanager
    def timed(self, part: str) -> Iterator[None]:
        if part not in PARTS:
            raise ValueError(f"unknown trainer part {part!r}; one of {', '.join(PARTS)}")
        bucket = self._seconds[self._bucket]
        started = time.monotonic()
        try:
            yield
        finally:
            bucket[part] = bucket.get(part, 0.0) + time.monotonic() - started

    @contextmanager
    def collecting(self) -> Iterator[None]:
        """Parts timed inside count as done while the workers play."""
        previous, self._bucket = self._bucket, WHILE_COLLECTING
        try:
            yield
        finally:
            self._bucket = previous

    def totals(self) -> dict[str, dict[str, float]]:
        """The seconds so far, rounded to the millisecond (what an iteration's summary carries)."""
        return {bucket: {part: round(s, 3) for part, s in parts.items()} for bucket, parts in self._seconds.items()}
