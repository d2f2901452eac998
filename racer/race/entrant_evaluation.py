"""How a race file becomes one `racer evaluate` run per entrant (docs/evaluation.md, "Races").

DeepRacer on AWS sends a submission to the SimApp's evaluation job; racer runs the same job (`--mode deepracer`):

* `maximumLaps` -> NUMBER_OF_TRIALS (`--trials`): the evaluation drives at most that many laps.
* `continuousLap` -> IS_CONTINUOUS (`--continuous`): laps run into each other, one reset budget for the run;
  otherwise every lap starts at the line with its own budget.
* `offTrackPenaltySeconds` / `collisionPenaltySeconds` -> OFF_TRACK_PENALTY / COLLISION_PENALTY.
* `maxResets` -> NUMBER_OF_RESETS (`--resets`; absent: the console's 10000, an exit costs the penalty only).
* `maxTimeInMinutes` -> a limit on *simulated* time from the start (DRoA: the job's wall-clock limit); when it
  passes, the laps finished so far are the entrant's result.
* `trackConfig` -> `--track` / `--direction`; `raceType` + `objectAvoidanceConfig` -> `--race-type` / `--race-param`.
"""

from __future__ import annotations

from racer.evaluation_worker.config import (
    CONSOLE_NUMBER_OF_RESETS,
    DeepRacerRules,
    EvaluationConfig,
    VideoOptions,
)
from racer.race.race_file import RaceDefinition, RaceFileError
from racer.shared.sim.generations.catalog import DEFAULT_GENERATION
from racer.shared.sim.tracks.catalog import resolve_track


def resolve_route(definition: RaceDefinition) -> str:
    """The route name of trackConfig (trackId + trackDirection), through racer's track resolution; the route must
    load, so a missing track stops the race before it starts."""
    from racer.shared.sim.tracks.track import Track

    key = "trackConfig.trackDirection" if definition.track_direction else "trackConfig.trackId"
    try:
        route = resolve_track(definition.track_id, definition.track_direction).world_name
        Track.load(route)
    except (ValueError, OSError) as error:
        raise RaceFileError(f"{definition.source}: {key}: {error}") from None
    return route


def deepracer_rules(definition: RaceDefinition) -> DeepRacerRules:
    return DeepRacerRules(
        number_of_trials=definition.maximum_laps,
        is_continuous=definition.continuous_lap,
        number_of_resets=CONSOLE_NUMBER_OF_RESETS if definition.max_resets is None else definition.max_resets,
        off_track_penalty_s=definition.off_track_penalty_s,
        collision_penalty_s=definition.collision_penalty_s,
    )


def evaluation_config(
    definition: RaceDefinition,
    *,
    route: str,
    model_prefix: str,
    seed: int,
    video: bool,
    mcap: bool = False,
    generation: str = DEFAULT_GENERATION,
) -> EvaluationConfig:
    """The `racer evaluate` job one entrant runs (time limit aside: see `maxTimeInMinutes` above)."""
    return EvaluationConfig(
        model_prefix=model_prefix,
        mode="deepracer",
        checkpoint="best",
        track=route,
        world="base",
        reverse_dir=False,
        deepracer=deepracer_rules(definition),
        challenge=definition.challenge_config(),
        video=VideoOptions(enabled=video),
        mcap=mcap,
        seed=seed,
        generation=generation,
    )
