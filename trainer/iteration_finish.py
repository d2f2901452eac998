"""The iteration's writes, split by who waits for them: the checkpoint the workers load next (published before the
next announcement), and the rest (the iteration's line in the store's log, retention, the summary on its Redis stream,
the episodes acknowledged), done after the next announcement while the workers play, or before `.finished`.
Each part is timed (racer.trainer.iteration_parts)."""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import torch

from racer.shared.deepracer.hyperparameters import Hyperparameters
from racer.shared.deepracer.model_metadata import ModelMetadata
from racer.shared.model_layout import ModelLayout
from racer.shared.policy.checkpoint_tensors import export_onnx
from racer.shared.policy.checkpoints import CheckpointStore
from racer.shared.store import ObjectStore
from racer.shared.transport.channels import RunChannel
from racer.trainer.iteration_parts import (
    ANNOUNCEMENTS,
    CHECKPOINT_FILES,
    CHECKPOINT_WRITES,
    ITERATIONS_LOG,
    ONNX_EXPORT,
    RETENTION,
    IterationParts,
)
from racer.trainer.iteration_summary import append_to_log


def save_checkpoint(
    checkpoints: CheckpointStore,
    parts: IterationParts,
    number: int,
    env_steps: int,
    network: torch.nn.Module,
    optimizer: torch.optim.Optimizer,
    model_metadata: ModelMetadata,
    hyperparameters: Hyperparameters,
    extra: Mapping,
) -> str:
    """Publish checkpoint `number` (CheckpointStore.save without its retention); returns its name."""
    with parts.timed(ONNX_EXPORT):
        onnx = export_onnx(network)
    with parts.timed(CHECKPOINT_FILES):
        files = checkpoints.checkpoint_files(
            number, env_steps, network, optimizer, model_metadata, hyperparameters, extra, onnx=onnx
        )
    with parts.timed(CHECKPOINT_WRITES):
        checkpoints.publish(files)
    return files.name


@dataclass(frozen=True)
class FinishingIteration:
    """A trained iteration whose checkpoint is published and whose records are not written yet."""

    summary: dict
    stream_ids: tuple[str, ...]
    iteration: int

    def finish_in_store(
        self, store: ObjectStore, layout: ModelLayout, checkpoints: CheckpointStore, parts: IterationParts
    ) -> None:
        """The log line first (the record), then retention."""
        with parts.timed(ITERATIONS_LOG):
            append_to_log(store, layout, self.summary)
        with parts.timed(RETENTION):
            checkpoints.apply_retention()

    def finish_in_redis(self, channel: RunChannel, parts: IterationParts, num_workers: int) -> None:
        with parts.timed(ANNOUNCEMENTS):
            channel.publish("iterations", self.summary)
            channel.ack(*self.stream_ids)
            channel.forget_iteration(self.iteration, num_workers)
