"""`ChallengeConfig`: what the car faces on the track (a time trial, obstacles or bot cars): DeepRacer's RACE_TYPE and
its obstacle / bot-car keys (deepracer-simapp v5.3.3 `bundle/markov/`; docs/custom-files.md), with the SimApp's
defaults.

As in the SimApp, the objects on the track come from the counts (`NUMBER_OF_OBSTACLES` or `OBJECT_POSITIONS`,
`NUMBER_OF_BOT_CARS`), and `RACE_TYPE` names what kind of race it is; racer refuses the combinations DeepRacer's
tools never produce (objects in a time trial) so that a forgotten key is an error, not a silent time trial.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, fields

RACE_TYPES: tuple[str, ...] = ("TIME_TRIAL", "OBJECT_AVOIDANCE", "HEAD_TO_BOT")
"""The race types of one env; HEAD_TO_MODEL and F1 (several trained cars) are multi-car runs
(`racer.evaluation_worker.multi_car`: `racer evaluate --opponent`)."""
MULTI_CAR_RACE_TYPES: tuple[str, ...] = ("HEAD_TO_MODEL", "F1")

OBSTACLE_TYPES: tuple[str, ...] = ("box_obstacle", "deepracer_box_obstacle", "amazon_box_obstacle")
"""The SimApp's OBSTACLE_TYPE_LIST; all three have the same 0.4 x 0.5 m collision rectangle (drawn as a box)."""

INNER_LANE = 1
OUTER_LANE = -1
"""OBJECT_POSITIONS lane codes, as the SimApp reads them ("ndist,lane": 1 inner, -1 outer)."""


def param_text(value: object) -> str:
    """A training_params value as text; a YAML/JSON list (OBJECT_POSITIONS) becomes DeepRacer-for-Cloud's `a;b`."""
    if isinstance(value, (list, tuple)):
        return ";".join(str(item) for item in value)
    return str(value)


@dataclass(frozen=True)
class ObjectPosition:
    """One fixed obstacle of OBJECT_POSITIONS: a fraction of the lap along the centre line, and a lane."""

    ndist: float
    lane: int
    """INNER_LANE (1) or OUTER_LANE (-1)."""


@dataclass(frozen=True)
class ChallengeConfig:
    """Field names follow the training_params.yaml keys; defaults are the SimApp's."""

    race_type: str = "TIME_TRIAL"
    number_of_obstacles: int = 0
    min_distance_between_obstacles: float = 2.0
    """Spacing of generated obstacles, in percent of the track length (the SimApp converts it so)."""
    randomize_obstacle_locations: bool = False
    is_obstacle_bot_car: bool = False
    """Static obstacles are parked bot cars (their 0.1961 x 0.32352 m rectangle) instead of boxes."""
    obstacle_type: str = "box_obstacle"
    object_positions: tuple[ObjectPosition, ...] = ()
    """Fixed obstacles; when given they replace NUMBER_OF_OBSTACLES and RANDOMIZE_OBSTACLE_LOCATIONS."""
    number_of_bot_cars: int = 0
    bot_car_speed_mps: float = 0.2
    is_lane_change: bool = False
    lower_lane_change_time_s: float = 3.0
    upper_lane_change_time_s: float = 5.0
    lane_change_distance_m: float = 1.0
    min_distance_between_bot_cars_m: float = 2.0
    randomize_bot_car_locations: bool = False
    penalty_seconds: float = 2.0
    """PENALTY_SECONDS: how long a bot car stops after it ran into the agent from behind."""
    enable_mercy_reset: bool = False
    """ENABLE_MERCY_RESET: after MAX_RESETS_AFTER_CRASH resets behind the same obstacle, reset ahead of it."""
    max_resets_after_crash: int = 3
    reset_behind_dist_m: float = 1.0
    """RESET_BEHIND_DIST: a reset near an obstacle puts the car this far behind it, on the other lane."""
    reset_ahead_dist_m: float = 1.0
    """RESET_AHEAD_DIST: where a mercy reset puts the car, ahead of the obstacle."""

    def __post_init__(self) -> None:
        if self.race_type in MULTI_CAR_RACE_TYPES:
            raise ValueError(
                f"RACE_TYPE: {self.race_type} puts several trained cars on the track: run it with `racer evaluate "
                f"--opponent MODEL` (evaluation_worker/multi_car.py), not as one env's race type"
            )
        if self.race_type not in RACE_TYPES:
            raise ValueError(f"RACE_TYPE: {self.race_type!r} is not one of {', '.join(RACE_TYPES)}")
        if self.obstacle_type not in OBSTACLE_TYPES:
            raise ValueError(f"OBSTACLE_TYPE: {self.obstacle_type!r} is not one of {', '.join(OBSTACLE_TYPES)}")
        for key, value in (
            ("NUMBER_OF_OBSTACLES", self.number_of_obstacles),
            ("NUMBER_OF_BOT_CARS", self.number_of_bot_cars),
        ):
            if not 0 <= value <= 20:
                raise ValueError(f"{key}: {value} is outside 0..20")
        for position in self.object_positions:
            if not 0.0 <= position.ndist <= 1.0 or position.lane not in (INNER_LANE, OUTER_LANE):
                raise ValueError(
                    f"OBJECT_POSITIONS: {position.ndist},{position.lane}: each entry is 'ndist,lane' with ndist in "
                    f"[0, 1] and lane 1 (inner) or -1 (outer)"
                )
        for key, value in (
            ("MIN_DISTANCE_BETWEEN_OBSTACLES", self.min_distance_between_obstacles),
            ("MIN_DISTANCE_BETWEEN_BOT_CARS", self.min_distance_between_bot_cars_m),
            ("LOWER_LANE_CHANGE_TIME", self.lower_lane_change_time_s),
            ("PENALTY_SECONDS", self.penalty_seconds),
            ("RESET_BEHIND_DIST", self.reset_behind_dist_m),
            ("RESET_AHEAD_DIST", self.reset_ahead_dist_m),
        ):
            if value < 0:
                raise ValueError(f"{key}: {value} must be >= 0")
        if self.bot_car_speed_mps <= 0 or self.bot_car_speed_mps > 4.0:
            raise ValueError(f"BOT_CAR_SPEED: {self.bot_car_speed_mps} m/s is outside (0, 4]")
        if self.lane_change_distance_m <= 0:
            raise ValueError(f"LANE_CHANGE_DISTANCE: {self.lane_change_distance_m} m must be > 0")
        if self.upper_lane_change_time_s < self.lower_lane_change_time_s:
            raise ValueError(
                f"UPPER_LANE_CHANGE_TIME: {self.upper_lane_change_time_s} s is below LOWER_LANE_CHANGE_TIME "
                f"{self.lower_lane_change_time_s} s"
            )
        if self.max_resets_after_crash < 1:
            raise ValueError(f"MAX_RESETS_AFTER_CRASH: {self.max_resets_after_crash} must be >= 1")
        if self.race_type == "OBJECT_AVOIDANCE" and self.num_obstacles == 0:
            raise ValueError("NUMBER_OF_OBSTACLES: RACE_TYPE OBJECT_AVOIDANCE needs obstacles (or OBJECT_POSITIONS)")
        if self.race_type == "HEAD_TO_BOT" and self.number_of_bot_cars == 0:
            raise ValueError("NUMBER_OF_BOT_CARS: RACE_TYPE HEAD_TO_BOT needs at least one bot car")
        if self.race_type == "TIME_TRIAL" and self.has_objects:
            raise ValueError(
                "RACE_TYPE: TIME_TRIAL with NUMBER_OF_OBSTACLES/OBJECT_POSITIONS/NUMBER_OF_BOT_CARS set; "
                "choose RACE_TYPE OBJECT_AVOIDANCE or HEAD_TO_BOT, or set the counts to 0"
            )

    @property
    def num_obstacles(self) -> int:
        """OBJECT_POSITIONS overrides NUMBER_OF_OBSTACLES, as in the SimApp."""
        return len(self.object_positions) if self.object_positions else self.number_of_obstacles

    @property
    def has_objects(self) -> bool:
        return self.num_obstacles > 0 or self.number_of_bot_cars > 0

    def to_training_params(self) -> dict[str, object]:
        """The yaml keys, values as strings (OBJECT_POSITIONS as DeepRacer's list of "ndist,lane")."""
        params: dict[str, object] = {"RACE_TYPE": self.race_type}
        for key, field_name in _KEYS.items():
            value = getattr(self, field_name)
            if field_name == "object_positions":
                if value:
                    params[key] = [f"{p.ndist},{p.lane}" for p in value]
                continue
            params[key] = str(value)
        return params

    @classmethod
    def from_training_params(cls, params: Mapping[str, object]) -> ChallengeConfig:
        """Read the keys (strings or YAML values); a bad value raises ValueError naming its key."""
        values: dict[str, object] = {}
        kinds = {f.name: f.type for f in fields(cls)}
        for key, field_name in {"RACE_TYPE": "race_type", **_KEYS}.items():
            if key not in params or params[key] is None or param_text(params[key]).strip() == "":
                continue
            raw = params[key]
            text = param_text(raw).strip()
            kind = kinds[field_name]
            try:
                if field_name == "object_positions":
                    values[field_name] = _parse_positions(raw)
                elif field_name == "race_type":
                    values[field_name] = text.upper()
                elif field_name == "obstacle_type":
                    values[field_name] = text
                elif kind == "bool":
                    lowered = text.lower()
                    if lowered not in {"true", "false", "1", "0"}:
                        raise ValueError("is not True or False")
                    values[field_name] = lowered in {"true", "1"}
                elif kind == "int":
                    number = float(text)
                    if not number.is_integer():
                        raise ValueError("is not a whole number")
                    values[field_name] = int(number)
                else:
                    values[field_name] = float(text)
            except ValueError as error:
                reason = str(error) if "is not" in str(error) or "entry" in str(error) else "is not a number"
                raise ValueError(f"{key}: {text!r} {reason}") from None
        return cls(**values)


def _parse_positions(raw: object) -> tuple[ObjectPosition, ...]:
    items = list(raw) if isinstance(raw, (list, tuple)) else [p for p in str(raw).split(";") if p.strip()]
    positions = []
    for item in items:
        parts = str(item).split(",")
        if len(parts) != 2:
            raise ValueError(f"entry {item!r} is not 'ndist,lane'")
        try:
            positions.append(ObjectPosition(float(parts[0]), int(float(parts[1]))))
        except ValueError:
            raise ValueError(f"entry {item!r} is not 'ndist,lane'") from None
    return tuple(positions)


_KEYS: dict[str, str] = {
    "NUMBER_OF_OBSTACLES": "number_of_obstacles",
    "MIN_DISTANCE_BETWEEN_OBSTACLES": "min_distance_between_obstacles",
    "RANDOMIZE_OBSTACLE_LOCATIONS": "randomize_obstacle_locations",
    "IS_OBSTACLE_BOT_CAR": "is_obstacle_bot_car",
    "OBSTACLE_TYPE": "obstacle_type",
    "OBJECT_POSITIONS": "object_positions",
    "NUMBER_OF_BOT_CARS": "number_of_bot_cars",
    "BOT_CAR_SPEED": "bot_car_speed_mps",
    "IS_LANE_CHANGE": "is_lane_change",
    "LOWER_LANE_CHANGE_TIME": "lower_lane_change_time_s",
    "UPPER_LANE_CHANGE_TIME": "upper_lane_change_time_s",
    "LANE_CHANGE_DISTANCE": "lane_change_distance_m",
    "MIN_DISTANCE_BETWEEN_BOT_CARS": "min_distance_between_bot_cars_m",
    "RANDOMIZE_BOT_CAR_LOCATIONS": "randomize_bot_car_locations",
    "PENALTY_SECONDS": "penalty_seconds",
    "ENABLE_MERCY_RESET": "enable_mercy_reset",
    "MAX_RESETS_AFTER_CRASH": "max_resets_after_crash",
    "RESET_BEHIND_DIST": "reset_behind_dist_m",
    "RESET_AHEAD_DIST": "reset_ahead_dist_m",
}
"""training_params.yaml key -> ChallengeConfig field."""

CHALLENGE_KEYS: tuple[str, ...] = ("RACE_TYPE", *_KEYS)
