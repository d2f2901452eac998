"""The rollout worker's claim rule: which episode of an iteration it plays next (keys: racer.shared.transport.channels),
and, in an overlapped run, the newer checkpoint it takes up before it starts that episode."""

from __future__ import annotations

import logging

from racer.shared.policy.checkpoints import CheckpointStore
from racer.shared.transport.channels import RunChannel

log = logging.getLogger(__name__)


def claim_next_episode(
    channel: RunChannel, iteration: int, worker_id: int, num_workers: int, own_in_flight: set[int]
) -> int | None:
    """The worker's claim rule: the next episode of its own DeepRacer share (added to `own_in_flight`, the own
    episodes it is playing); once its own share is all claimed and played, an unclaimed episode of a slower worker's
    share (racer.shared.transport.channels.RunChannel.claim_other). None when there is nothing to claim now."""
    number = channel.claim_own(iteration, worker_id)
    if number is not None:
        own_in_flight.add(number)
    elif not own_in_flight:  # its own share is played: help with what is left
        live = channel.live_workers()
        number = channel.claim_other(iteration, worker_id, num_workers, live)
    return number


def newer_policy(channel: RunChannel, checkpoints: CheckpointStore, held_version: int):
    """An overlapped run: (version, policy) of a checkpoint newer than the one held, once the trainer has written
    one; None otherwise. The worker takes it up when an env starts its next episode."""
    newest = channel.newest_checkpoint()
    if newest is None or newest[0] <= held_version:
        return None
    log.info("taking up checkpoint %s (version %d) between episodes", newest[1], newest[0])
    return newest[0], load_policy(checkpoints, newest[1])


def load_policy(checkpoints: CheckpointStore, checkpoint: str):
    """A checkpoint's inference policy, ready to act."""
    policy = checkpoints.load_inference_policy(checkpoint)
    policy.eval()
    return policy
