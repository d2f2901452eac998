"""What an evaluation run is asked to do: which rules, which car, which outputs. Frozen, validated on creation."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

from racer.shared.deepracer.model_metadata import ModelMetadata
from racer.shared.run_settings import JobSettings
from racer.shared.sim.car.dynamics import CAR_PROFILE_NAMES
from racer.shared.sim.config import DEFAULT_TRACK, RESET_POSITIONS
from racer.shared.sim.generations.catalog import DEFAULT_GENERATION, GENERATION_NAMES
from racer.shared.sim.objects.challenge import ChallengeConfig
from racer.shared.sim.scene.worlds import WORLD_NAMES
from racer.shared.worker_settings import WorkerSettings

MODES: tuple[str, ...] = ("deepracer", "race")
MIN_RESET_COUNT = 2
"""The SimApp accepts NUMBER_OF_RESETS = 0 or >= 2 (evaluation_worker MIN_RESET_COUNT)."""
CONSOLE_NUMBER_OF_RESETS = 10000
"""What the AWS console sends as NUMBER_OF_RESETS for an evaluation (console 2022 evaluation log): in effect no
limit, so an off-track costs the penalty pause and the lap goes on."""


class EvaluationConfigError(ValueError):
    """An evaluation setting that cannot work; the message names the option."""


@dataclass(frozen=True)
class DeepRacerRules:
    """The SimApp evaluation job's parameters (deepracer-simapp v5.3.3 `bundle/markov/evaluation_worker.py`), defaults
    as the AWS console sends them."""

    number_of_trials: int = 3
    """NUMBER_OF_TRIALS: laps (trials) to evaluate."""
    is_continuous: bool = False
    """IS_CONTINUOUS: all trials in one run without stopping at the line (reset budget shared by the run)."""
    number_of_resets: int = CONSOLE_NUMBER_OF_RESETS
    """NUMBER_OF_RESETS: pause-and-reset events allowed per trial (per run if continuous) before a rule ends it
    (0 = the first exit ends it)."""
    off_track_penalty_s: float = 2.0
    """OFF_TRACK_PENALTY: seconds the car waits after being put back (also used for `reversed`)."""
    collision_penalty_s: float = 5.0
    immobilized_penalty_s: float = 0.0

    def __post_init__(self) -> None:
        if self.number_of_trials < 1:
            raise EvaluationConfigError(f"--trials (NUMBER_OF_TRIALS) must be >= 1, got {self.number_of_trials}")
        if self.number_of_resets != 0 and self.number_of_resets < MIN_RESET_COUNT:
            raise EvaluationConfigError(
                f"--resets (NUMBER_OF_RESETS) must be 0 or >= {MIN_RESET_COUNT} as in the SimApp, got {self.number_of_resets}"
            )
        for name in ("off_track_penalty_s", "collision_penalty_s", "immobilized_penalty_s"):
            if getattr(self, name) < 0:
                raise EvaluationConfigError(f"{name} must be >= 0, got {getattr(self, name)}")


@dataclass(frozen=True)
class SummitRules:
    """The AWS Summit physical-track rule: drive for a fixed time, up to 3 put-backs per lap."""

    race_duration_s: float = 240.0
    """Simulated seconds from the first start to the end of the run (4 minutes)."""
    resets_per_lap: int = 3
    """Put-backs allowed in one lap; leaving the track once more ends the lap attempt."""
    reset_penalty_s: float = 2.0
    """Seconds the car is held after being put back (the marshal's time); the clock keeps running. On a physical
    track a marshal walks to the car and sets it down: that is never instant, and with 0 s a put-back that saved a
    bend could beat driving it. 2 s is also DeepRacer's own off-track penalty."""
    put_back: str = "where_it_left"
    """`where_it_left`: on the centre line where the car last had all four wheels on the road, half its last step
    back (the seed's summit-rule code; any progress made while leaving is given back). `deepracer`: the SimApp's
    respawn spot (previous progress, nearer lane)."""
    continuous: bool = True
    """Completed laps run straight into the next one (as on a physical track); False = restart each lap at the line."""

    def __post_init__(self) -> None:
        if not self.race_duration_s > 0:
            raise EvaluationConfigError(f"--race-minutes must be > 0, got {self.race_duration_s / 60.0} min")
        if self.resets_per_lap < 0:
            raise EvaluationConfigError(f"--race-resets-per-lap must be >= 0, got {self.resets_per_lap}")
        if self.reset_penalty_s < 0:
            raise EvaluationConfigError(f"--race-reset-penalty must be >= 0, got {self.reset_penalty_s}")
        if self.put_back not in RESET_POSITIONS:
            raise EvaluationConfigError(
                f"--race-put-back must be one of {', '.join(RESET_POSITIONS)}, got {self.put_back!r}"
            )


@dataclass(frozen=True)
class VideoOptions:
    enabled: bool = True
    width_px: int = 480
    """Size of the top view and the 45-degree follow view (the in-car view is the car camera, upscaled x2)."""
    height_px: int = 360
    follow_distance_m: float = 1.2
    follow_elevation_deg: float = -45.0

    def __post_init__(self) -> None:
        if not (16 <= self.width_px <= 640 and 16 <= self.height_px <= 480):
            raise EvaluationConfigError(
                f"--video-size must be within 16x16 .. 640x480 (the scene's offscreen buffer), got {self.width_px}x{self.height_px}"
            )
        if self.width_px % 2 or self.height_px % 2:
            raise EvaluationConfigError(
                f"--video-size needs even sizes (H.264 yuv420p), got {self.width_px}x{self.height_px}"
            )


@dataclass(frozen=True)
class EvaluationConfig:
    """One evaluation: the model, the rules, the world and the outputs."""

    model_prefix: str
    mode: str = "deepracer"
    checkpoint: str = "best"
    """`best`, `last` or a checkpoint name such as `3_Step-1234.ckpt` (EVAL_CHECKPOINT)."""
    track: str | Path = DEFAULT_TRACK
    world: str = "base"
    reverse_dir: bool = False
    deepracer: DeepRacerRules = field(default_factory=DeepRacerRules)
    summit: SummitRules = field(default_factory=SummitRules)
    challenge: ChallengeConfig = ChallengeConfig()
    """RACE_TYPE and the obstacles / bot cars on the track (both modes); crashes cost COLLISION_PENALTY (deepracer
    mode) or the put-back penalty (the summit rule) and count as a reset."""
    video: VideoOptions = field(default_factory=VideoOptions)
    mcap: bool = True
    seed: int = 0
    """Seeds the LIDAR noise; the sim clock starts at 0."""
    car_profile: str = ""
    """RACER_CAR_PROFILE: a car (`car.dynamics.CAR_DYNAMICS`) instead of the generation's; "" = the generation's."""
    generation: str = DEFAULT_GENERATION
    """RACER_GENERATION: the DeepRacer simulator the evaluation stands in for (look and car)."""

    def __post_init__(self) -> None:
        if self.generation not in GENERATION_NAMES:
            raise EvaluationConfigError(
                f"--generation (RACER_GENERATION) must be one of {', '.join(GENERATION_NAMES)}, got {self.generation!r}"
            )
        if self.car_profile and self.car_profile not in CAR_PROFILE_NAMES:
            raise EvaluationConfigError(
                f"--car-profile (RACER_CAR_PROFILE) must be one of {', '.join(CAR_PROFILE_NAMES)}, "
                f"got {self.car_profile!r}"
            )
        if self.mode not in MODES:
            raise EvaluationConfigError(f"--mode must be one of {', '.join(MODES)}, got {self.mode!r}")
        if self.world not in WORLD_NAMES:
            raise EvaluationConfigError(f"--world must be one of {', '.join(WORLD_NAMES)}, got {self.world!r}")
        if not self.model_prefix.strip("/"):
            raise EvaluationConfigError("--model-prefix must not be empty")

    def run_settings(self, model_metadata: ModelMetadata) -> tuple[WorkerSettings, JobSettings]:
        """This evaluation as a worker's settings and a job's (racer.shared.run_settings.env_config builds the env
        from them, as for a rollout worker): DeepRacer's default evaluation reward, the start on the line, the mode's
        reset budget and penalties."""
        if self.mode == "race":
            penalty = self.summit.reset_penalty_s
            resets, off_track, collision = self.summit.resets_per_lap, penalty, penalty
            job = JobSettings(model_metadata, None, penalty, penalty, self.summit.put_back)
        else:
            rules = self.deepracer
            resets, off_track, collision = rules.number_of_resets, rules.off_track_penalty_s, rules.collision_penalty_s
            job = JobSettings(model_metadata, None, rules.immobilized_penalty_s, None, "deepracer")
        settings = WorkerSettings(
            world=self.world,
            track=self.track,  # type: ignore[arg-type]  # a Path stays a Path (EnvConfig.track takes both)
            reverse_dir=self.reverse_dir,
            number_of_resets=resets,
            off_track_penalty_s=off_track,
            collision_penalty_s=collision,
            car_profile=self.car_profile,
            generation=self.generation,
            challenge=self.challenge,
        )
        return settings, job
