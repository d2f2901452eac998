"""`EnvConfig`: everything one DeepRacer environment instance depends on, with the SimApp's defaults."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from racer.shared.deepracer.model_metadata import ModelMetadata, parse_model_metadata
from racer.shared.sim.car.dynamics import CarDynamics
from racer.shared.sim.generations.catalog import DEFAULT_GENERATION, generation
from racer.shared.sim.generations.looks import GenerationLook
from racer.shared.sim.objects.challenge import ChallengeConfig
from racer.shared.sim.scene.worlds import WORLD_NAMES

DEFAULT_TRACK = "racer_oval"
"""The short quick-start track shipped in `tracks/`."""

RESET_POSITIONS: tuple[str, ...] = ("deepracer", "where_it_left")
"""Where a reset rule puts the car back: the SimApp's spot, or where it left the road (the summit rule's marshal)."""

STEPS_PER_SECOND = 15
"""DeepRacer's camera rate: one env step per camera frame."""
MAX_EPISODE_STEPS = 100_000

DEFAULT_MODEL_METADATA: ModelMetadata = parse_model_metadata(
    {
        "action_space": [
            {"steering_angle": steering, "speed": speed}
            for speed in (1.0, 2.0)
            for steering in (-30.0, -15.0, 0.0, 15.0, 30.0)
        ],
        "sensor": ["FRONT_FACING_CAMERA"],
        "neural_network": "DEEP_CONVOLUTIONAL_NETWORK_SHALLOW",
        "training_algorithm": "clipped_ppo",
        "action_space_type": "discrete",
        "version": "5",
    },
    source="racer default model_metadata",
)
"""10 discrete actions (5 steering angles × 1 and 2 m/s), front camera."""


@dataclass(frozen=True)
class EnvConfig:
    """Configuration of `DeepRacerEnv`. Field names follow the SimApp's yaml keys where one exists."""

    track: str | Path = DEFAULT_TRACK
    """Track name (looked up in `tracks_dir`) or path to a route `.npy` (WORLD_NAME)."""
    tracks_dir: Path | None = None
    """Where track names are looked up; None = the repository's `tracks/` folder."""
    world: str = "base"
    """One of `worlds.WORLD_NAMES`: base, carpet, concrete, wood."""
    model_metadata: ModelMetadata = DEFAULT_MODEL_METADATA
    """Action space and sensors (model_metadata.json)."""
    reward_function_path: Path | None = None
    """The user's reward file; None = DeepRacer's default evaluation reward."""
    reverse_dir: bool = False
    """REVERSE_DIR: drive the route in the opposite direction."""
    alternate_driving_direction: bool = False
    """ALTERNATE_DRIVING_DIRECTION: flip the direction after every training episode."""
    change_start_position: bool = True
    """CHANGE_START_POSITION: round-robin start; advance after every training episode."""
    round_robin_advance_dist: float = 0.05
    """ROUND_ROBIN_ADVANCE_DIST: fraction of a lap the start moves per training episode."""
    start_position_offset: float = 0.0
    """START_POSITION_OFFSET: initial start position, fraction of a lap."""
    number_of_resets: int = 0
    """NUMBER_OF_RESETS: pause-and-reset events allowed per episode before a rule ends it (0 in training)."""
    off_track_penalty_s: float = 2.0
    collision_penalty_s: float = 5.0
    reverse_penalty_s: float | None = None
    """None = the off-track penalty, as the SimApp."""
    immobilized_penalty_s: float = 0.0
    reset_position: str = "deepracer"
    """Where the car goes back after a reset rule: `deepracer` = the SimApp's spot (previous progress from the route
    origin, nearer lane); `where_it_left` = on the centre line where the car last had all four wheels on the road,
    half its last step further back, as the seed's summit-rule code and a marshal do (the summit rule)."""
    number_of_reverse_counts: int = 15
    """NUMBER_OF_REVERSE_COUNTS: consecutive steps of decreasing progress that mean `reversed`."""
    immobilized_steps: int = 15
    immobilized_distance_m: float = 0.0003
    max_steps: int = MAX_EPISODE_STEPS
    physics_substeps: int = 16
    """MuJoCo steps per env step (timestep = 1 / (15 · substeps) s)."""
    image_width_px: int = 160
    image_height_px: int = 120
    simapp_dir: Path | None = None
    """A SimApp checkout's `bundle/` folder (worlds/, models/, meshes/): draw DeepRacer's own world meshes and
    textures (`worlds/reinvent_<world>.world`) instead of racer's look. They fit the re:Invent 2018 route only."""
    domain_randomization: bool = False
    """ENABLE_DOMAIN_RANDOMIZATION: random light colours and attenuation at every reset, as the SimApp."""
    car_randomization: bool = False
    """racer's RACER_CAR_RANDOMIZATION: per-episode material tint and brightness, camera blur, noise and pose
    jitter, for models meant for the physical car (see domain_randomization.py)."""
    dynamics_randomization: bool = False
    """racer's RACER_DYNAMICS_RANDOMIZATION: at every training reset a car drawn around one generation's car or
    `car_dynamics` (both axles' stiffness, yaw inertia, steering servo, a 0-1 step command delay; see
    dynamics_randomization.py)."""
    render_full_resolution: bool = False
    """True = DeepRacer's path: render 640×480, bilinear-resize to the image size (PIL, as the SimApp).
    False (default) = render the image size directly, several times cheaper with software GL."""
    generation: str = DEFAULT_GENERATION
    """racer's RACER_GENERATION: which DeepRacer simulator this env stands in for (`generations.GENERATIONS`: 2019,
    simapp5, simapp6); it sets the look (lights, walls, camera) and, unless `car_dynamics` is given, the car."""
    car_dynamics: CarDynamics | None = None
    """The car's tyres, steering servo and yaw inertia; None (the default) = the generation's car, filled in at
    construction (a car profile, `car.dynamics.CAR_DYNAMICS`, replaces it: docs/car-and-camera.md)."""
    look: GenerationLook | None = None
    """What the camera sees; None (the default) = the generation's look, filled in at construction (a perturbed look
    for the robustness bench)."""
    challenge: ChallengeConfig = ChallengeConfig()
    """RACE_TYPE and the obstacle / bot-car keys; the default is a time trial (nothing on the track)."""

    def __post_init__(self) -> None:
        try:
            chosen = generation(self.generation)
        except ValueError as error:
            raise ValueError(f"EnvConfig.generation: {error}") from None
        # The generation's car and look where none is given: frozen, so set once here.
        if self.car_dynamics is None:
            object.__setattr__(self, "car_dynamics", chosen.car)
        if self.look is None:
            object.__setattr__(self, "look", chosen.look)
        if self.world not in WORLD_NAMES:
            raise ValueError(f"EnvConfig.world: unknown world {self.world!r}; choose one of {', '.join(WORLD_NAMES)}")
        if not 0.0 <= self.round_robin_advance_dist < 1.0:
            raise ValueError(
                f"EnvConfig.round_robin_advance_dist must be in [0, 1), got {self.round_robin_advance_dist}"
            )
        if self.number_of_resets < 0:
            raise ValueError(f"EnvConfig.number_of_resets must be >= 0, got {self.number_of_resets}")
        for name in ("off_track_penalty_s", "collision_penalty_s", "immobilized_penalty_s"):
            if getattr(self, name) < 0:
                raise ValueError(f"EnvConfig.{name} must be >= 0, got {getattr(self, name)}")
        if self.reset_position not in RESET_POSITIONS:
            raise ValueError(
                f"EnvConfig.reset_position must be one of {', '.join(RESET_POSITIONS)}, got {self.reset_position!r}"
            )
        if self.number_of_reverse_counts < 1 or self.immobilized_steps < 1:
            raise ValueError("EnvConfig.number_of_reverse_counts and immobilized_steps must be >= 1")
        if self.max_steps < 2:
            raise ValueError(f"EnvConfig.max_steps must be >= 2, got {self.max_steps}")
        if self.physics_substeps < 1:
            raise ValueError(f"EnvConfig.physics_substeps must be >= 1, got {self.physics_substeps}")
        if (
            self.image_width_px < 8
            or self.image_height_px < 8
            or self.image_width_px > 640
            or self.image_height_px > 480
        ):
            raise ValueError("EnvConfig image size must be within 8x8 .. 640x480")

    @property
    def step_duration_s(self) -> float:
        return 1.0 / STEPS_PER_SECOND

    @property
    def effective_reverse_penalty_s(self) -> float:
        return self.off_track_penalty_s if self.reverse_penalty_s is None else self.reverse_penalty_s
