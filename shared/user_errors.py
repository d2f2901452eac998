"""Errors caused by the user's files or services, shown as one clear message instead of a traceback.

Each names the file and field (or the service URL) already; a traceback would only hide that line.
Reward functions that raise keep their own traceback inside the message (file and line of the user's code).
"""

from __future__ import annotations


def user_error_types() -> tuple[type[Exception], ...]:
    from racer.shared.deepracer.hyperparameters import HyperparametersError
    from racer.shared.deepracer.model_metadata import ModelMetadataError
    from racer.shared.deepracer.simtrace import SimtraceError
    from racer.shared.policy.manifest import CheckpointError
    from racer.shared.redis_connection import RedisUnavailableError
    from racer.shared.sim.reward.function import RewardFunctionError
    from racer.shared.sim.scene.gl import GLBackendError
    from racer.shared.sim.tracks.track import TrackError
    from racer.shared.store import StoreError

    return (
        HyperparametersError,
        ModelMetadataError,
        SimtraceError,
        RedisUnavailableError,
        GLBackendError,
        RewardFunctionError,
        TrackError,
        StoreError,
        CloneError,
        RunConfigError,
        CheckpointError,
        UnsupportedConfigurationError,
        RunCannotGoOnError,
    )


class CloneError(ValueError):
    """A model cannot continue from another one (different number of actions, sensors or network)."""


class RunConfigError(ValueError):
    """A run setting (workers.json, training_params.yaml) that cannot work."""


class UnsupportedConfigurationError(ValueError):
    """A configuration DeepRacer refuses, or one racer cannot train yet: names the file, the field, why and the fix.
    (The trainer's preflight, racer.trainer.preflight, raises it.)"""


class RunCannotGoOnError(RuntimeError):
    """A process of the run reported an error no restart can mend (the reward function raised during training);
    the message is that process's, naming the file, the line and the params."""
