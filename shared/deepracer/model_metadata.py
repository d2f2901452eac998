"""`model_metadata.json`: the action space, sensors and network of a DeepRacer model, read, checked and written
(the types it fills are in `model_description.py`, importable from here too).

Rules follow the SimApp parser (defaults, sensor combinations, SAC needs a continuous space) plus the ranges the
console and DRoA enforced when a model was created (discrete: 2-30 actions, speed 0.1-4.0 m/s, steering within
+-30 deg; continuous: speed 0.5-4.0 m/s). Keys the SimApp ignores (`preprocess_type`, `regional_parameters`, ...)
are ignored here too, so every file found in the wild still loads. Source: deepracer-simapp v5.3.3
`bundle/markov/boto/s3/files/model_metadata.py`; keys: docs/custom-files.md.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from os import PathLike
from pathlib import Path

from racer.shared.deepracer._jsonfile import read_json_file
from racer.shared.deepracer.model_description import (
    CAMERA_SENSORS,
    LIDAR_SENSORS,
    SENSOR_NAMES,
    ContinuousActionSpace,
    DiscreteAction,
    LidarConfig,
    ModelMetadata,
)

__all__ = [
    "ACTION_SPACE_TYPES",
    "CAMERA_SENSORS",
    "LIDAR_SENSORS",
    "NEURAL_NETWORKS",
    "SENSOR_NAMES",
    "TRAINING_ALGORITHMS",
    "ContinuousActionSpace",
    "DiscreteAction",
    "LidarConfig",
    "ModelMetadata",
    "ModelMetadataError",
    "load_model_metadata",
    "model_metadata_to_dict",
    "parse_model_metadata",
]


class ModelMetadataError(ValueError):
    """A model_metadata.json that DeepRacer would reject; the message names the file, the field and what is allowed."""


NETWORK_FILE = "network.json"
NEURAL_NETWORKS: tuple[str, ...] = (
    "DEEP_CONVOLUTIONAL_NETWORK_SHALLOW",
    "DEEP_CONVOLUTIONAL_NETWORK",
    "DEEP_CONVOLUTIONAL_NETWORK_DEEP",
)
ACTION_SPACE_TYPES: tuple[str, ...] = ("discrete", "continuous")
TRAINING_ALGORITHMS: tuple[str, ...] = ("clipped_ppo", "sac")

MIN_DISCRETE_ACTIONS = 2
MAX_DISCRETE_ACTIONS = 30
MIN_SPEED_MPS = 0.1
MIN_CONTINUOUS_SPEED_MPS = 0.5
MAX_SPEED_MPS = 4.0
MAX_STEERING_ANGLE_DEG = 30.0
LIDAR_NUM_SECTORS_ALLOWED: tuple[int, ...] = (1, 2, 4, 8, 16, 32, 64)
"""Divisors of the 64 LIDAR samples (the SimApp requires 64 % num_sectors == 0)."""
LIDAR_MIN_CLIPPING_DIST_M = 0.15
LIDAR_MAX_CLIPPING_DIST_M = 12.0
"""The simulated LIDAR's range; a clipping distance outside it could never be reached."""


class _Checker:
    """Builds error messages of the form '<file>: <field>: <problem>'."""

    def __init__(self, source: str) -> None:
        self.source = source

    def error(self, field: str, problem: str) -> ModelMetadataError:
        return ModelMetadataError(f"{self.source}: {field}: {problem}")

    def number(self, value: object, field: str) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.error(field, f"{value!r} is not a number")
        if not math.isfinite(value):
            raise self.error(field, f"{value!r} is not a finite number")
        return float(value)

    def in_range(self, value: object, field: str, low: float, high: float, unit: str) -> float:
        number = self.number(value, field)
        if number < low:
            raise self.error(field, f"{number} is below {low} {unit}")
        if number > high:
            raise self.error(field, f"{number} is above {high} {unit}")
        return number

    def mapping(self, value: object, field: str) -> Mapping[str, object]:
        if not isinstance(value, Mapping):
            raise self.error(field, f"expected a JSON object, got {type(value).__name__}")
        return value

    def choice(self, value: object, field: str, allowed: tuple[str, ...], normalise: bool) -> str:
        if not isinstance(value, str):
            raise self.error(field, f"{value!r} is not a string; allowed: {', '.join(allowed)}")
        text = value.strip().lower() if normalise else value
        if text not in allowed:
            raise self.error(field, f"{value!r} is not allowed; allowed: {', '.join(allowed)}")
        return text

    def integer(self, value: object, field: str) -> int:
        if isinstance(value, bool):
            raise self.error(field, f"{value!r} is not an integer")
        if isinstance(value, float) and value.is_integer():
            return int(value)
        if not isinstance(value, int):
            raise self.error(field, f"{value!r} is not an integer")
        return value


def _parse_discrete(check: _Checker, action_space: object) -> tuple[DiscreteAction, ...]:
    if not isinstance(action_space, list):
        raise check.error(
            "action_space",
            "a discrete action space must be a list of {steering_angle, speed} objects "
            "(an object with low/high ranges needs action_space_type 'continuous')",
        )
    count = len(action_space)
    if not MIN_DISCRETE_ACTIONS <= count <= MAX_DISCRETE_ACTIONS:
        raise check.error(
            "action_space",
            f"{count} actions; a discrete action space has {MIN_DISCRETE_ACTIONS} to {MAX_DISCRETE_ACTIONS} actions",
        )
    actions = []
    for position, entry in enumerate(action_space):
        field = f"action_space[{position}]"
        item = check.mapping(entry, field)
        for key in ("steering_angle", "speed"):
            if key not in item:
                raise check.error(field, f"missing key {key!r}")
        steering = check.in_range(
            item["steering_angle"], f"{field}.steering_angle", -MAX_STEERING_ANGLE_DEG, MAX_STEERING_ANGLE_DEG, "deg"
        )
        speed = check.in_range(item["speed"], f"{field}.speed", MIN_SPEED_MPS, MAX_SPEED_MPS, "m/s")
        if "index" in item:
            index = check.integer(item["index"], f"{field}.index")
            if index != position:
                raise check.error(
                    f"{field}.index",
                    f"{index} does not match the action's position {position} (list order is the index)",
                )
        actions.append(DiscreteAction(steering_angle_deg=steering, speed_mps=speed))
    return tuple(actions)


def _parse_range(check: _Checker, space: Mapping[str, object], key: str) -> tuple[object, object]:
    if key not in space:
        raise check.error("action_space", f"missing key {key!r} (a continuous space needs steering_angle and speed)")
    bounds = check.mapping(space[key], f"action_space.{key}")
    for bound in ("low", "high"):
        if bound not in bounds:
            raise check.error(f"action_space.{key}", f"missing key {bound!r}")
    return bounds["low"], bounds["high"]


def _parse_continuous(check: _Checker, action_space: object) -> ContinuousActionSpace:
    if not isinstance(action_space, Mapping):
        raise check.error(
            "action_space",
            "a continuous action space must be an object {steering_angle: {low, high}, speed: {low, high}} "
            "(a list of actions needs action_space_type 'discrete')",
        )
    steer_low, steer_high = _parse_range(check, action_space, "steering_angle")
    speed_low, speed_high = _parse_range(check, action_space, "speed")
    limit = MAX_STEERING_ANGLE_DEG
    space = ContinuousActionSpace(
        steering_angle_low_deg=check.in_range(steer_low, "action_space.steering_angle.low", -limit, limit, "deg"),
        steering_angle_high_deg=check.in_range(steer_high, "action_space.steering_angle.high", -limit, limit, "deg"),
        speed_low_mps=check.in_range(
            speed_low, "action_space.speed.low", MIN_CONTINUOUS_SPEED_MPS, MAX_SPEED_MPS, "m/s"
        ),
        speed_high_mps=check.in_range(
            speed_high, "action_space.speed.high", MIN_CONTINUOUS_SPEED_MPS, MAX_SPEED_MPS, "m/s"
        ),
    )
    if not space.steering_angle_low_deg < space.steering_angle_high_deg:
        raise check.error(
            "action_space.steering_angle",
            f"low {space.steering_angle_low_deg} must be below high {space.steering_angle_high_deg}",
        )
    if not space.speed_low_mps < space.speed_high_mps:
        raise check.error("action_space.speed", f"low {space.speed_low_mps} must be below high {space.speed_high_mps}")
    return space


def _parse_version(check: _Checker, value: object) -> float:
    """Real files carry "3", "4.0", "5" (strings) or numbers."""
    if isinstance(value, str):
        try:
            version = float(value.strip())
        except ValueError:
            raise check.error("version", f'{value!r} is not a number (e.g. "5" or 5.0)') from None
    else:
        version = check.number(value, "version")
    if not math.isfinite(version) or version < 1.0:
        raise check.error("version", f"{value!r} is not a SimApp version (1.0 or higher)")
    return version


def _parse_sensors(check: _Checker, value: object) -> tuple[str, ...]:
    if not isinstance(value, list):
        raise check.error("sensor", f"expected a list of sensor names, got {type(value).__name__}")
    sensors = []
    for position, name in enumerate(value):
        if not isinstance(name, str) or name not in SENSOR_NAMES:
            raise check.error(f"sensor[{position}]", f"{name!r} is not a sensor; allowed: {', '.join(SENSOR_NAMES)}")
        if name in sensors:
            raise check.error(f"sensor[{position}]", f"{name!r} is listed twice")
        sensors.append(name)
    cameras = [name for name in sensors if name in CAMERA_SENSORS]
    lidars = [name for name in sensors if name in LIDAR_SENSORS]
    if len(cameras) != 1:
        raise check.error("sensor", f"needs exactly one camera of {', '.join(CAMERA_SENSORS)}; got {cameras or 'none'}")
    if len(lidars) > 1:
        raise check.error("sensor", f"at most one lidar of {', '.join(LIDAR_SENSORS)}; got {lidars}")
    return tuple(sensors)


def _parse_lidar_config(check: _Checker, value: object) -> LidarConfig:
    config = check.mapping(value, "lidar_config")
    defaults = LidarConfig()
    num_sectors = defaults.num_sectors
    if "num_sectors" in config:
        num_sectors = check.integer(config["num_sectors"], "lidar_config.num_sectors")
        if num_sectors not in LIDAR_NUM_SECTORS_ALLOWED:
            raise check.error(
                "lidar_config.num_sectors",
                f"{num_sectors} does not divide the 64 lidar samples; allowed: "
                f"{', '.join(str(n) for n in LIDAR_NUM_SECTORS_ALLOWED)}",
            )
    num_values = defaults.num_values_per_sector
    if "num_values_per_sector" in config:
        num_values = check.integer(config["num_values_per_sector"], "lidar_config.num_values_per_sector")
        if num_values < 1:
            raise check.error("lidar_config.num_values_per_sector", f"{num_values} is below 1")
    clipping = defaults.clipping_dist_m
    if "clipping_dist" in config:
        clipping = check.in_range(
            config["clipping_dist"],
            "lidar_config.clipping_dist",
            LIDAR_MIN_CLIPPING_DIST_M,
            LIDAR_MAX_CLIPPING_DIST_M,
            "m",
        )
    return LidarConfig(num_sectors=num_sectors, num_values_per_sector=num_values, clipping_dist_m=clipping)


def parse_model_metadata(data: object, source: str = "model_metadata.json") -> ModelMetadata:
    """Validate a decoded model_metadata.json and fill in the SimApp defaults for missing keys."""
    check = _Checker(source)
    if not isinstance(data, Mapping):
        raise ModelMetadataError(f"{source}: expected a JSON object at the top level, got {type(data).__name__}")

    action_space_type = "discrete"
    if "action_space_type" in data:
        action_space_type = check.choice(data["action_space_type"], "action_space_type", ACTION_SPACE_TYPES, True)

    training_algorithm = "clipped_ppo"
    if "training_algorithm" in data:
        training_algorithm = check.choice(data["training_algorithm"], "training_algorithm", TRAINING_ALGORITHMS, True)
    if training_algorithm == "sac" and action_space_type != "continuous":
        raise check.error("training_algorithm", "'sac' requires action_space_type 'continuous'")

    if "action_space" not in data:
        raise check.error("action_space", "missing; every model needs an action space")
    discrete_actions: tuple[DiscreteAction, ...] = ()
    continuous_space = None
    if action_space_type == "discrete":
        discrete_actions = _parse_discrete(check, data["action_space"])
    else:
        continuous_space = _parse_continuous(check, data["action_space"])

    has_sensor = "sensor" in data
    if "version" in data:
        version = _parse_version(check, data["version"])
    else:
        version = 2.0 if has_sensor else 1.0
    if has_sensor:
        sensors = _parse_sensors(check, data["sensor"])
    elif version >= 2.0:
        raise check.error("sensor", f"missing; version {version} models must list their sensors")
    else:
        sensors = ("observation",)

    neural_network = NEURAL_NETWORKS[0]
    if "neural_network" in data:
        neural_network = _parse_neural_network(check, data["neural_network"])

    lidar_config = LidarConfig()
    if "lidar_config" in data:
        lidar_config = _parse_lidar_config(check, data["lidar_config"])

    return ModelMetadata(
        action_space_type=action_space_type,
        discrete_actions=discrete_actions,
        continuous_action_space=continuous_space,
        sensors=sensors,
        neural_network=neural_network,
        training_algorithm=training_algorithm,
        version=version,
        lidar_config=lidar_config,
    )


def _parse_neural_network(check: _Checker, value: object) -> str:
    """One of DeepRacer's three networks, or the name of your own (a network.json beside model_metadata.json defines
    it: racer.shared.policy.network_file checks that file where the network is built)."""
    if isinstance(value, str) and value.strip() and value.isprintable() and len(value) <= 64:
        return value
    raise check.error(
        "neural_network",
        f"{value!r} is not allowed; allowed: {', '.join(NEURAL_NETWORKS)}, or the name of your own network in a "
        f"{NETWORK_FILE} beside this file",
    )


def load_model_metadata(path: str | PathLike[str]) -> ModelMetadata:
    """Read and validate a model_metadata.json file; errors name the file (and line/column for bad JSON). A
    `neural_network` that is not one of DeepRacer's three must be the `name` of the network.json beside it."""
    metadata = parse_model_metadata(read_json_file(path, ModelMetadataError), source=str(path))
    if metadata.neural_network not in NEURAL_NETWORKS:
        network_path = Path(path).parent / NETWORK_FILE
        name = None
        if network_path.is_file():
            data = read_json_file(network_path, ModelMetadataError)
            name = data.get("name") if isinstance(data, dict) else None
        if name != metadata.neural_network:
            found = f"its name is {name!r}" if network_path.is_file() else "there is none"
            raise ModelMetadataError(
                f"{path}: neural_network: {metadata.neural_network!r} is not one of DeepRacer's networks "
                f"({', '.join(NEURAL_NETWORKS)}), so it must be the name of {network_path}, but {found}; fix: name a "
                f'built-in network, or give {NETWORK_FILE} "name": "{metadata.neural_network}"'
            )
    return metadata


def _json_number(value: float) -> int | float:
    """Whole numbers as ints (e.g. steering 30, version "5"), so files read like the ones DeepRacer tools write."""
    return int(value) if float(value).is_integer() else value


def model_metadata_to_dict(metadata: ModelMetadata) -> dict[str, object]:
    """The DeepRacer JSON form (key names and layout of DRfC/console files); parse_model_metadata reads it back."""
    if metadata.continuous_action_space is not None:
        space = metadata.continuous_action_space
        action_space: object = {
            "steering_angle": {"high": space.steering_angle_high_deg, "low": space.steering_angle_low_deg},
            "speed": {"high": space.speed_high_mps, "low": space.speed_low_mps},
        }
    else:
        action_space = [
            {"steering_angle": action.steering_angle_deg, "speed": action.speed_mps, "index": index}
            for index, action in enumerate(metadata.discrete_actions)
        ]
    lidar = metadata.lidar_config
    return {
        "action_space": action_space,
        "sensor": list(metadata.sensors),
        "neural_network": metadata.neural_network,
        "training_algorithm": metadata.training_algorithm,
        "action_space_type": metadata.action_space_type,
        "version": str(_json_number(metadata.version)),
        "lidar_config": {
            "num_sectors": lidar.num_sectors,
            "num_values_per_sector": lidar.num_values_per_sector,
            "clipping_dist": lidar.clipping_dist_m,
        },
    }
