"""`training_params.yaml` / `evaluation_params.yaml`: the simulation-side settings of a DeepRacer job.

The SimApp reads these flat yaml files key by key with its own defaults. DRfC and the console write every value as
a string ("true", "0.05", "None"); multi-car jobs write some keys as lists with one value per car (the console's
`CAR_COLOR: ['Black']`); hand-written files may use plain yaml numbers and booleans. All of them load: values are
kept as strings (lists as tuples of strings) and the typed accessors convert on use, naming the file and the key
when a value does not fit. Keys and defaults: docs/custom-files.md.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from os import PathLike
from types import MappingProxyType

import yaml

__all__ = [
    "TrainingParams",
    "TrainingParamsError",
    "load_training_params",
    "parse_training_params",
    "training_params_to_yaml",
]


class TrainingParamsError(ValueError):
    """A training/evaluation params yaml that cannot be used; the message names the file and the key."""


Value = str | tuple[str, ...]

_TRUE = ("true",)
_FALSE = ("false",)


def _to_text(value: object, where: str) -> str:
    """yaml scalars as the string DRfC would have written (True -> "True", 0.05 -> "0.05", null -> "")."""
    if value is None:
        return ""
    if isinstance(value, (str, bool, int, float)):
        return str(value)
    raise TrainingParamsError(f"{where}: {value!r} is not a scalar (string, number or boolean)")


def _normalise(key: object, value: object, source: str) -> tuple[str, Value]:
    if not isinstance(key, str):
        raise TrainingParamsError(f"{source}: key {key!r} is not a string")
    where = f"{source}: {key}"
    if isinstance(value, (list, tuple)):
        return key, tuple(_to_text(item, f"{where}[{index}]") for index, item in enumerate(value))
    return key, _to_text(value, where)


@dataclass(frozen=True)
class TrainingParams:
    """The key/value pairs of one params yaml (strings, or tuples of strings for per-car lists), in file order."""

    values: Mapping[str, Value] = field(default_factory=dict)
    source: str = "training_params.yaml"

    def __post_init__(self) -> None:
        pairs = dict(_normalise(key, value, self.source) for key, value in dict(self.values).items())
        object.__setattr__(self, "values", MappingProxyType(pairs))

    def __contains__(self, key: object) -> bool:
        return key in self.values

    def __getitem__(self, key: str) -> Value:
        return self.values[key]

    def _scalar(self, key: str, racecar_index: int) -> str:
        value = self.values[key]
        if isinstance(value, tuple):
            if not 0 <= racecar_index < len(value):
                raise TrainingParamsError(
                    f"{self.source}: {key}: has {len(value)} per-car values, no value for car {racecar_index}"
                )
            return value[racecar_index]
        return value

    def get_str(self, key: str, default: str | None = None, racecar_index: int = 0) -> str:
        """The value as written; for per-car lists the value of car `racecar_index`. Missing and no default: error."""
        if key not in self.values:
            if default is None:
                raise TrainingParamsError(f"{self.source}: {key}: missing")
            return default
        return self._scalar(key, racecar_index)

    def get_bool(self, key: str, default: bool | None = None, racecar_index: int = 0) -> bool:
        """'true'/'True'/'TRUE' or 'false'/... (yaml booleans too)."""
        if key not in self.values and default is not None:
            return default
        text = self.get_str(key, racecar_index=racecar_index).strip().lower()
        if text in _TRUE:
            return True
        if text in _FALSE:
            return False
        raise TrainingParamsError(f"{self.source}: {key}: {self._scalar(key, racecar_index)!r} is not true or false")

    def get_float(self, key: str, default: float | None = None, racecar_index: int = 0) -> float:
        if key not in self.values and default is not None:
            return default
        text = self.get_str(key, racecar_index=racecar_index)
        try:
            number = float(text)
        except ValueError:
            raise TrainingParamsError(f"{self.source}: {key}: {text!r} is not a number") from None
        if not math.isfinite(number):
            raise TrainingParamsError(f"{self.source}: {key}: {text!r} is not a finite number")
        return number

    def get_int(self, key: str, default: int | None = None, racecar_index: int = 0) -> int:
        """Whole numbers, also when written as '3.0'."""
        if key not in self.values and default is not None:
            return default
        number = self.get_float(key, racecar_index=racecar_index)
        if not number.is_integer():
            raise TrainingParamsError(
                f"{self.source}: {key}: {self._scalar(key, racecar_index)!r} is not a whole number"
            )
        return int(number)

    def get_list(self, key: str) -> tuple[str, ...]:
        """Per-car values; a single value counts as a one-car list."""
        value = self.values[key] if key in self.values else ()
        return value if isinstance(value, tuple) else (value,)

    # The keys racer's simulation reads, with the SimApp's defaults (docs/custom-files.md).

    @property
    def job_type(self) -> str:
        return self.get_str("JOB_TYPE", "TRAINING")

    @property
    def world_name(self) -> str:
        """Route name (`routes/<WORLD_NAME>.npy`); required."""
        name = self.get_str("WORLD_NAME")
        if not name:
            raise TrainingParamsError(f"{self.source}: WORLD_NAME: empty; it names the track's route file")
        return name

    @property
    def race_type(self) -> str:
        return self.get_str("RACE_TYPE", "TIME_TRIAL")

    @property
    def change_start_position(self) -> bool:
        return self.get_bool("CHANGE_START_POSITION", True)

    @property
    def round_robin_advance_dist(self) -> float:
        """Fraction of the lap the start moves after each training episode."""
        return self.get_float("ROUND_ROBIN_ADVANCE_DIST", 0.05)

    @property
    def start_position_offset(self) -> float:
        return self.get_float("START_POSITION_OFFSET", 0.0)

    @property
    def alternate_driving_direction(self) -> bool:
        return self.get_bool("ALTERNATE_DRIVING_DIRECTION", False)

    @property
    def reverse_dir(self) -> bool:
        return self.get_bool("REVERSE_DIR", False)

    @property
    def number_of_resets(self) -> int:
        return self.get_int("NUMBER_OF_RESETS", 0)

    @property
    def min_eval_trials(self) -> int:
        return self.get_int("MIN_EVAL_TRIALS", 5)

    @property
    def best_model_metric(self) -> str:
        return self.get_str("BEST_MODEL_METRIC", "progress")

    @property
    def number_of_trials(self) -> int:
        return self.get_int("NUMBER_OF_TRIALS", 10)

    @property
    def is_continuous(self) -> bool:
        return self.get_bool("IS_CONTINUOUS", False)

    @property
    def off_track_penalty_s(self) -> float:
        return self.get_float("OFF_TRACK_PENALTY", 2.0)

    @property
    def collision_penalty_s(self) -> float:
        return self.get_float("COLLISION_PENALTY", 5.0)

    @property
    def number_of_obstacles(self) -> int:
        return self.get_int("NUMBER_OF_OBSTACLES", 0)

    @property
    def number_of_bot_cars(self) -> int:
        return self.get_int("NUMBER_OF_BOT_CARS", 0)

    @property
    def enable_domain_randomization(self) -> bool:
        return self.get_bool("ENABLE_DOMAIN_RANDOMIZATION", False)

    @property
    def num_workers(self) -> int:
        return self.get_int("NUM_WORKERS", 1)


def parse_training_params(text: str, source: str = "training_params.yaml") -> TrainingParams:
    """Parse yaml text; syntax errors name the file, line and column."""
    try:
        data = yaml.safe_load(text)
    except yaml.MarkedYAMLError as error:
        mark = error.problem_mark or error.context_mark
        position = f"line {mark.line + 1}, column {mark.column + 1}: " if mark is not None else ""
        raise TrainingParamsError(f"{source}: invalid YAML at {position}{error.problem or error}") from None
    except yaml.YAMLError as error:
        raise TrainingParamsError(f"{source}: invalid YAML: {error}") from None
    if data is None:
        data = {}
    if not isinstance(data, Mapping):
        raise TrainingParamsError(
            f"{source}: expected a mapping of KEY: value at the top level, got {type(data).__name__}"
        )
    return TrainingParams(values=data, source=source)


def load_training_params(path: str | PathLike[str]) -> TrainingParams:
    with open(path, "rb") as handle:
        raw = handle.read()
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as error:
        raise TrainingParamsError(f"{path}: not UTF-8 text (byte {error.start})") from None
    return parse_training_params(text, source=str(path))


def training_params_to_yaml(params: TrainingParams | Mapping[str, object]) -> str:
    """Every value as a double-quoted string (as DRfC writes them), keys in the given order, with a `---` start."""
    if not isinstance(params, TrainingParams):
        params = TrainingParams(values=params)
    plain = {key: list(value) if isinstance(value, tuple) else value for key, value in params.values.items()}
    return yaml.safe_dump(
        plain, default_style='"', explicit_start=True, sort_keys=False, allow_unicode=True, width=1000
    )
