"""`racer rollout`: one rollout worker process."""

from __future__ import annotations

import logging
import signal

import click

from racer.rollout_worker.envs import DEFAULT_ENVS_PER_WORKER
from racer.shared.config import settings_from_env
from racer.shared.sim.reward.function import RewardFunctionError
from racer.shared.sim.scene.worlds import WORLD_NAMES as WORLDS
from racer.shared.user_errors import user_error_types

EXIT_RUN_CANNOT_GO_ON = 3
"""Exit status of a worker whose failure a restart cannot mend (the reward function raised on a pose the run met):
`racer train` stops the run instead of restarting the worker, as the SimApp's RewardFunctionError ends its job."""


@click.command(name="rollout")
@click.option("--model-prefix", required=True, help="Model name: the store prefix of the training run to join.")
@click.option("--worker-id", type=click.IntRange(0, 63), required=True, help="0-based; worker 0 also evaluates.")
@click.option("--world", type=click.Choice(WORLDS), default=None, help="Override the world from training_params.")
@click.option("--track", default=None, help="Override the track from training_params.")
@click.option("--seed", type=int, default=0, show_default=True)
@click.option(
    "--envs",
    type=click.IntRange(1, 64),
    default=DEFAULT_ENVS_PER_WORKER,
    show_default=True,
    help="Envs of its world the worker steps at once (one batched forward pass picks all their actions).",
)
@click.option(
    "--wait-timeout-s",
    type=float,
    default=3600.0,
    show_default=True,
    help="Longest wait for the trainer's next checkpoint before exiting with an error.",
)
def rollout_command(model_prefix, worker_id, world, track, seed, envs, wait_timeout_s) -> None:
    """Simulate one world and feed episodes to the trainer (Redis and store from RACER_REDIS_URL / RACER_STORE)."""
    from racer.rollout_worker.worker import RolloutOptions, RolloutWorker

    logging.basicConfig(level=logging.INFO, format=f"%(asctime)s %(levelname)s worker-{worker_id}: %(message)s")
    try:
        worker = RolloutWorker(
            settings_from_env(),
            RolloutOptions(
                model_prefix=model_prefix,
                worker_id=worker_id,
                seed=seed,
                wait_timeout_s=wait_timeout_s,
                world_override=world,
                track_override=track,
                envs=envs,
            ),
        )
        signal.signal(signal.SIGTERM, lambda signum, frame: worker.stop())
        signal.signal(signal.SIGINT, lambda signum, frame: worker.stop())
        worker.run_forever()
    except RewardFunctionError as error:
        _stop_the_run(model_prefix, worker_id, str(error))
    except user_error_types() as error:
        raise click.ClickException(str(error)) from error


def _stop_the_run(model_prefix: str, worker_id: int, message: str) -> None:
    """Tell the trainer and `racer train` (a Redis key) that the run cannot go on, then exit with its own status."""
    from racer.shared.redis_connection import RedisLink, RedisUnavailableError
    from racer.shared.transport.channels import RunChannel

    click.echo(f"Error: worker {worker_id}: {message}", err=True)
    try:
        RunChannel(RedisLink(settings_from_env().redis, reconnect_budget_s=5.0), model_prefix).report_fatal(
            f"worker {worker_id}", message
        )
    except RedisUnavailableError as error:  # the exit status still stops a local run
        click.echo(f"(could not tell the trainer through Redis: {error})", err=True)
    raise SystemExit(EXIT_RUN_CANNOT_GO_ON)
