"""The rollout worker's claim rule: which episode of an iteration it plays next (keys: racer.shared.transport.channels)."""

from __future__ import annotations

from racer.shared.transport.channels import RunChannel


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
