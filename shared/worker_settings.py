"""One rollout worker's world and episode settings, and how they map onto DeepRacer's training_params.yaml keys.

The keys of a model folder (where these settings are stored, per worker) live in racer.shared.model_layout.
"""

from __future__ import annotations

from dataclasses import dataclass, fields

from racer.shared.sim.config import DEFAULT_TRACK
from racer.shared.sim.route_search import world_name_for_direction
from racer.shared.sim.worlds import WORLD_NAMES as WORLDS

__all__ = ["WorkerSettings", "default_worker_settings"]


@dataclass(frozen=True)
class WorkerSettings:
    """One rollout worker's world and episode settings (DeepRacer-for-Cloud's worker-N.env)."""

    world: str = "base"
    """Surface and look: base, carpet, concrete or wood."""
    track: str = DEFAULT_TRACK
    """Route name (WORLD_NAME: looked up on the route search path, RACER_ROUTES_PATH then tracks/) or a path to a
    DeepRacer .npy route file. TRACK_DIRECTION_CLOCKWISE appends `_cw`/`_ccw` as DeepRacer-on-AWS does."""
    reverse_dir: bool = False
    alternate_driving_direction: bool = False
    change_start_position: bool = True
    round_robin_advance_dist: float = 0.05
    start_position_offset: float = 0.0
    min_eval_trials: int = 5
    """Greedy evaluation episodes per checkpoint (worker 0 only)."""
    best_model_metric: str = "progress"
    """progress, reward or laptime: how deepracer_checkpoints.json picks the best checkpoint."""
    eval_spread_starts: bool = False
    """racer's option (training_params key RACER_EVAL_SPREAD_STARTS): evaluation trial i of n starts i/n of a lap
    further on. DeepRacer starts them all at one place; in a deterministic simulator they would all be the same
    drive, so spread starts make "3 of 3 laps" mean three different laps."""

    def __post_init__(self) -> None:
        if self.world not in WORLDS:
            raise ValueError(f"world {self.world!r} is not one of {', '.join(WORLDS)}")
        if self.best_model_metric not in {"progress", "reward", "laptime"}:
            raise ValueError(f"BEST_MODEL_METRIC {self.best_model_metric!r} is not progress, reward or laptime")
        if not 0.0 <= self.round_robin_advance_dist <= 1.0:
            raise ValueError(f"ROUND_ROBIN_ADVANCE_DIST {self.round_robin_advance_dist} is outside [0, 1]")

    def to_training_params(self, model_prefix: str, num_workers: int) -> dict[str, str]:
        """DeepRacer's training_params.yaml keys, all values strings as DeepRacer-for-Cloud writes them."""
        return {
            "JOB_TYPE": "TRAINING",
            "WORLD_NAME": self.track,
            "RACER_WORLD": self.world,
            "RACE_TYPE": "TIME_TRIAL",
            "SAGEMAKER_SHARED_S3_PREFIX": model_prefix,
            "NUM_WORKERS": str(num_workers),
            "REVERSE_DIR": str(self.reverse_dir),
            "ALTERNATE_DRIVING_DIRECTION": str(self.alternate_driving_direction),
            "CHANGE_START_POSITION": str(self.change_start_position),
            "ROUND_ROBIN_ADVANCE_DIST": str(self.round_robin_advance_dist),
            "START_POSITION_OFFSET": str(self.start_position_offset),
            "MIN_EVAL_TRIALS": str(self.min_eval_trials),
            "BEST_MODEL_METRIC": self.best_model_metric,
            "NUMBER_OF_RESETS": "0",
            "RACER_EVAL_SPREAD_STARTS": str(self.eval_spread_starts),
        }

    @classmethod
    def from_training_params(cls, params: dict[str, str], source: str) -> WorkerSettings:
        def flag(name: str, default: bool) -> bool:
            raw = str(params.get(name, default)).strip().lower()
            if raw not in {"true", "false", "1", "0"}:
                raise ValueError(f"{source}: {name}: {params[name]!r} is not True or False")
            return raw in {"true", "1"}

        defaults = cls()
        clockwise = flag("TRACK_DIRECTION_CLOCKWISE", False) if "TRACK_DIRECTION_CLOCKWISE" in params else None
        try:
            return cls(
                world=str(params.get("RACER_WORLD", defaults.world)),
                track=world_name_for_direction(str(params.get("WORLD_NAME", defaults.track)), clockwise),
                reverse_dir=flag("REVERSE_DIR", defaults.reverse_dir),
                alternate_driving_direction=flag("ALTERNATE_DRIVING_DIRECTION", defaults.alternate_driving_direction),
                change_start_position=flag("CHANGE_START_POSITION", defaults.change_start_position),
                round_robin_advance_dist=float(params.get("ROUND_ROBIN_ADVANCE_DIST", defaults.round_robin_advance_dist)),
                start_position_offset=float(params.get("START_POSITION_OFFSET", defaults.start_position_offset)),
                min_eval_trials=int(params.get("MIN_EVAL_TRIALS", defaults.min_eval_trials)),
                best_model_metric=str(params.get("BEST_MODEL_METRIC", defaults.best_model_metric)).lower(),
                eval_spread_starts=flag("RACER_EVAL_SPREAD_STARTS", defaults.eval_spread_starts),
            )
        except ValueError as error:
            raise ValueError(f"{source}: {error}") from error

    def replace(self, **changes) -> WorkerSettings:
        values = {f.name: getattr(self, f.name) for f in fields(self)}
        values.update({k: v for k, v in changes.items() if v is not None})
        return WorkerSettings(**values)


def default_worker_settings(num_workers: int, track: str = DEFAULT_TRACK,
                            worlds: tuple[str, ...] = WORLDS) -> list[WorkerSettings]:
    """Worker i gets world i (cycling through `worlds`) on the same track."""
    return [WorkerSettings(world=worlds[i % len(worlds)], track=track) for i in range(num_workers)]
