"""A race file: DeepRacer on AWS's `LeaderboardDefinition` (leaderboard.smithy) under its own names, in YAML/JSON.

    name: club-cup                       # optional; default: the file name
    trackConfig: {trackId: reinvent_base, trackDirection: COUNTER_CLOCKWISE}
    raceType: TIME_TRIAL                 # TIME_TRIAL | OBJECT_AVOIDANCE; racer's additions HEAD_TO_BOT, HEAD_TO_MODEL, F1
    timingMethod: AVG_LAP_TIME           # BEST_LAP_TIME | AVG_LAP_TIME | TOTAL_TIME
    resettingBehaviorConfig: {continuousLap: true, offTrackPenaltySeconds: 2, collisionPenaltySeconds: 5}
    submissionTerminationConditions: {minimumLaps: 3, maximumLaps: 5, maxTimeInMinutes: 20}
    maxResets: 10000                     # optional (NUMBER_OF_RESETS)
    objectAvoidanceConfig: {numberOfObjects: 2, objectPositions: [{laneNumber: 1, trackPercentage: 0.3}, ...]}
    NUMBER_OF_BOT_CARS: 2                # racer's additions: the SimApp's training_params names
    DONE_CONDITION: all                  # HEAD_TO_MODEL / F1 only: any | all; START_POS_OFFSET: 0.75 (m, 0..1)

Every key is checked before anything starts; an unknown key or a bad value raises RaceFileError naming the file
and the key (`trackConfig.trackDirection`).
"""

from __future__ import annotations

import json
import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import yaml

from racer.shared.sim.objects.challenge import ChallengeConfig

MULTI_CAR_RACE_TYPES = ("HEAD_TO_MODEL", "F1")
"""Every entrant on the track at once, in one multi-car evaluation (evaluation_worker/multi_car.py)."""
RACE_TYPES = ("TIME_TRIAL", "OBJECT_AVOIDANCE", "HEAD_TO_BOT", *MULTI_CAR_RACE_TYPES)
TIMING_METHODS = ("BEST_LAP_TIME", "AVG_LAP_TIME", "TOTAL_TIME")
DIRECTIONS = ("CLOCKWISE", "COUNTER_CLOCKWISE")
DEFAULT_MAX_TIME_MINUTES = 20.0
"""DRoA's default when a leaderboard gives no maxTimeInMinutes (createSubmission: `?? 20`)."""
RACE_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9-]{0,63}$")
IGNORED_KEYS = ("description", "openTime", "closeTime", "maxSubmissionsPerUser", "leaderBoardFooter", "isLive")
"""DRoA keys that schedule or describe an online race; accepted and not used by a local race."""
_SIMAPP_KEYS = tuple(
    key
    for key in ChallengeConfig(race_type="HEAD_TO_BOT", number_of_bot_cars=1).to_training_params()
    if key not in ("RACE_TYPE", "NUMBER_OF_OBSTACLES", "OBJECT_POSITIONS")
)
"""racer's additions: the SimApp's training_params names ChallengeConfig reads (bot cars, obstacle details)."""
_MULTI_CAR_KEYS = ("DONE_CONDITION", "START_POS_OFFSET")
"""racer's additions for HEAD_TO_MODEL / F1: the SimApp's training_params names (`evaluation_worker.py`)."""


class RaceFileError(ValueError):
    """A race file that cannot run; the message names the file and the key."""


@dataclass(frozen=True)
class ObjectPlacement:
    lane_number: int
    """1 inside lane, -1 outside lane (the SimApp's OBJECT_POSITIONS lane codes)."""
    track_percentage: float
    """Fraction of the lap, 0..1."""


@dataclass(frozen=True)
class RaceDefinition:
    name: str
    source: str
    """The file it came from, for messages."""
    track_id: str
    track_direction: str | None
    race_type: str
    timing_method: str
    continuous_lap: bool
    off_track_penalty_s: float
    collision_penalty_s: float
    minimum_laps: int
    maximum_laps: int
    max_time_minutes: float
    max_resets: int | None
    number_of_objects: int = 0
    object_positions: tuple[ObjectPlacement, ...] = ()
    simapp_params: tuple[tuple[str, str], ...] = ()
    description: str = ""

    def challenge_config(self) -> ChallengeConfig:
        """RACE_TYPE and the objects as `racer evaluate --race-type/--race-param` would build them."""
        if self.multi_car:  # the other cars are the entrants, not one env's track objects
            return ChallengeConfig()
        params: dict[str, object] = {"RACE_TYPE": self.race_type, **dict(self.simapp_params)}
        if self.race_type == "OBJECT_AVOIDANCE":
            params["NUMBER_OF_OBSTACLES"] = str(self.number_of_objects)
            if self.object_positions:
                params["OBJECT_POSITIONS"] = [f"{p.track_percentage},{p.lane_number}" for p in self.object_positions]
        return ChallengeConfig.from_training_params(params)

    @property
    def multi_car(self) -> bool:
        return self.race_type in MULTI_CAR_RACE_TYPES

    def multi_car_rules(self):
        """HEAD_TO_MODEL / F1: `maximumLaps` laps each (NUMBER_OF_TRIALS), DONE_CONDITION and START_POS_OFFSET as
        given (else the SimApp's), the race stopped at `maxTimeInMinutes` of simulated time."""
        from racer.evaluation_worker.multi_car import START_POS_OFFSET_M, MultiCarRules

        params = dict(self.simapp_params)
        return MultiCarRules(
            race_type=self.race_type,
            laps=self.maximum_laps,
            start_pos_offset_m=float(params.get("START_POS_OFFSET", START_POS_OFFSET_M)),
            done_condition=params["DONE_CONDITION"].strip().lower() if "DONE_CONDITION" in params else None,
            max_race_s=self.max_time_minutes * 60.0,
        )

    def to_dict(self) -> dict[str, Any]:
        """The definition back under DRoA's names (written into leaderboard.json)."""
        data: dict[str, Any] = {
            "name": self.name,
            "trackConfig": {"trackId": self.track_id, "trackDirection": self.track_direction},
            "raceType": self.race_type,
            "timingMethod": self.timing_method,
            "resettingBehaviorConfig": {
                "continuousLap": self.continuous_lap,
                "offTrackPenaltySeconds": self.off_track_penalty_s,
                "collisionPenaltySeconds": self.collision_penalty_s,
            },
            "submissionTerminationConditions": {
                "minimumLaps": self.minimum_laps,
                "maximumLaps": self.maximum_laps,
                "maxTimeInMinutes": self.max_time_minutes,
            },
            "maxResets": self.max_resets,
        }
        if self.race_type == "OBJECT_AVOIDANCE":
            data["objectAvoidanceConfig"] = {
                "numberOfObjects": self.number_of_objects,
                "objectPositions": [
                    {"laneNumber": p.lane_number, "trackPercentage": p.track_percentage} for p in self.object_positions
                ],
            }
        data.update(dict(self.simapp_params))
        return data


class _Reader:
    """Checks one mapping's keys and values; every message names the file and the dotted key."""

    def __init__(self, source: str, data: object, where: str = "") -> None:
        self.source = source
        self.where = where
        if not isinstance(data, Mapping):
            raise self.error(where or "(top level)", f"expected a mapping, got {type(data).__name__}")
        self.data = dict(data)

    def error(self, key: str, message: str) -> RaceFileError:
        return RaceFileError(f"{self.source}: {key}: {message}")

    def path(self, key: str) -> str:
        return f"{self.where}.{key}" if self.where else key

    def refuse_unknown(self, allowed: tuple[str, ...]) -> None:
        for key in self.data:
            if key not in allowed:
                raise self.error(self.path(str(key)), f"unknown key; expected one of {', '.join(allowed)}")

    def has(self, key: str) -> bool:
        return self.data.get(key) is not None

    def sub(self, key: str, required: bool = True) -> _Reader:
        if not self.has(key):
            if required:
                raise self.error(self.path(key), "missing")
            return _Reader(self.source, {}, self.path(key))
        return _Reader(self.source, self.data[key], self.path(key))

    def choice(self, key: str, choices: tuple[str, ...], default: str | None = None) -> str | None:
        if not self.has(key):
            if default is None and key not in ("trackDirection",):
                raise self.error(self.path(key), f"missing; expected one of {', '.join(choices)}")
            return default
        value = str(self.data[key]).strip().upper()
        if value not in choices:
            raise self.error(self.path(key), f"{self.data[key]!r} is not one of {', '.join(choices)}")
        return value

    def integer(self, key: str, low: int, high: int, default: int | None = None) -> int:
        if not self.has(key):
            if default is None:
                raise self.error(self.path(key), f"missing; expected a whole number in {low}..{high}")
            return default
        value = self.data[key]
        if isinstance(value, bool) or not isinstance(value, int | float) or float(value) != int(value):
            raise self.error(self.path(key), f"{value!r} is not a whole number")
        if not low <= int(value) <= high:
            raise self.error(self.path(key), f"{value} is outside {low}..{high}")
        return int(value)

    def number(self, key: str, low: float, high: float, default: float, *, low_open: bool = False) -> float:
        if not self.has(key):
            return default
        value = self.data[key]
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.error(self.path(key), f"{value!r} is not a number")
        if value < low or value > high or (low_open and value == low):
            bracket = "(" if low_open else "["
            raise self.error(self.path(key), f"{value} is outside {bracket}{low}, {high}]")
        return float(value)

    def flag(self, key: str, default: bool) -> bool:
        if not self.has(key):
            return default
        value = self.data[key]
        if not isinstance(value, bool):
            raise self.error(self.path(key), f"{value!r} is not true or false")
        return value


def _object_avoidance(top: _Reader, race_type: str) -> tuple[int, tuple[ObjectPlacement, ...]]:
    if race_type != "OBJECT_AVOIDANCE":
        if top.has("objectAvoidanceConfig"):
            raise top.error("objectAvoidanceConfig", f"given for raceType {race_type}; only OBJECT_AVOIDANCE uses it")
        return 0, ()
    config = top.sub("objectAvoidanceConfig")
    config.refuse_unknown(("numberOfObjects", "objectPositions"))
    count = config.integer("numberOfObjects", 1, 10)
    raw = config.data.get("objectPositions") or []
    if not isinstance(raw, list):
        raise config.error(config.path("objectPositions"), "expected a list of {laneNumber, trackPercentage}")
    positions = []
    for index, item in enumerate(raw):
        entry = _Reader(config.source, item, config.path(f"objectPositions[{index}]"))
        entry.refuse_unknown(("laneNumber", "trackPercentage"))
        lane = entry.integer("laneNumber", -1, 1)
        if lane == 0:
            raise entry.error(entry.path("laneNumber"), "0 is not a lane; use 1 (inside) or -1 (outside)")
        positions.append(ObjectPlacement(lane, entry.number("trackPercentage", 0.0, 1.0, -1.0)))
        if positions[-1].track_percentage < 0:
            raise entry.error(entry.path("trackPercentage"), "missing; expected a fraction of the lap in [0, 1]")
    if positions and len(positions) != count:
        raise config.error(
            config.path("objectPositions"), f"{len(positions)} positions for numberOfObjects {count}; give one each"
        )
    return count, tuple(positions)


def _check_race_type_keys(top: _Reader, race_type: str) -> None:
    """Bot-car and obstacle keys belong to one env's race; DONE_CONDITION / START_POS_OFFSET to a multi-car one."""
    multi = race_type in MULTI_CAR_RACE_TYPES
    for key in _MULTI_CAR_KEYS if not multi else _SIMAPP_KEYS:
        if top.has(key):
            use = "HEAD_TO_MODEL and F1 use it" if not multi else "a multi-car race has no obstacles or bot cars"
            raise top.error(key, f"given for raceType {race_type}; {use}")
    if top.has("DONE_CONDITION") and str(top.data["DONE_CONDITION"]).strip().lower() not in ("any", "all"):
        raise top.error("DONE_CONDITION", f"{top.data['DONE_CONDITION']!r} is not any or all")
    if top.has("START_POS_OFFSET"):  # a number (or its text: to_dict writes the SimApp's values as text)
        value = top.data["START_POS_OFFSET"]
        try:
            offset = float(value) if not isinstance(value, bool) else -1.0
        except (TypeError, ValueError):
            offset = -1.0
        if not 0.0 <= offset <= 1.0:
            raise top.error("START_POS_OFFSET", f"{value!r} is not a distance in [0, 1] m")


def parse_race(data: object, source: str, default_name: str) -> RaceDefinition:
    top = _Reader(source, data)
    known = (
        "name",
        "trackConfig",
        "raceType",
        "timingMethod",
        "resettingBehaviorConfig",
        "submissionTerminationConditions",
        "maxResets",
        "objectAvoidanceConfig",
        *IGNORED_KEYS,
        *_SIMAPP_KEYS,
        *_MULTI_CAR_KEYS,
    )
    top.refuse_unknown(known)
    name = str(top.data.get("name") or default_name)
    if not RACE_NAME.match(name):
        raise top.error("name", f"{name!r}: use 1-64 letters, digits and hyphens (it becomes the store prefix)")
    track = top.sub("trackConfig")
    track.refuse_unknown(("trackId", "trackDirection"))
    if not track.has("trackId") or not str(track.data["trackId"]).strip():
        raise track.error("trackConfig.trackId", "missing")
    race_type = top.choice("raceType", RACE_TYPES)
    _check_race_type_keys(top, assert_str(race_type))
    timing = top.choice("timingMethod", TIMING_METHODS)
    resetting = top.sub("resettingBehaviorConfig", required=False)
    resetting.refuse_unknown(("continuousLap", "offTrackPenaltySeconds", "collisionPenaltySeconds"))
    limits = top.sub("submissionTerminationConditions")
    limits.refuse_unknown(("minimumLaps", "maximumLaps", "maxTimeInMinutes"))
    minimum = limits.integer("minimumLaps", 1, 100)
    maximum = limits.integer("maximumLaps", 1, 100)
    if maximum < minimum:
        raise limits.error(limits.path("maximumLaps"), f"{maximum} is below minimumLaps {minimum}")
    max_resets = top.integer("maxResets", 0, 10000, default=-1)
    if max_resets == 1:
        raise top.error("maxResets", "1 is not allowed: 0 (the first exit ends the lap) or >= 2, as the SimApp")
    count, positions = _object_avoidance(top, assert_str(race_type))
    simapp = tuple((key, str(top.data[key])) for key in (*_SIMAPP_KEYS, *_MULTI_CAR_KEYS) if top.has(key))
    definition = RaceDefinition(
        name=name,
        source=source,
        track_id=str(track.data["trackId"]).strip(),
        track_direction=track.choice("trackDirection", DIRECTIONS),
        race_type=assert_str(race_type),
        timing_method=assert_str(timing),
        continuous_lap=resetting.flag("continuousLap", False),
        off_track_penalty_s=resetting.number("offTrackPenaltySeconds", 0.0, 60.0, 2.0),
        collision_penalty_s=resetting.number("collisionPenaltySeconds", 0.0, 60.0, 5.0),
        minimum_laps=minimum,
        maximum_laps=maximum,
        max_time_minutes=limits.number("maxTimeInMinutes", 0.0, 1440.0, DEFAULT_MAX_TIME_MINUTES, low_open=True),
        max_resets=None if max_resets < 0 else max_resets,
        number_of_objects=count,
        object_positions=positions,
        simapp_params=simapp,
        description=str(top.data.get("description") or ""),
    )
    try:
        definition.challenge_config()
        if definition.multi_car:
            definition.multi_car_rules()
    except ValueError as error:
        raise RaceFileError(f"{source}: {error}") from None
    return definition


def assert_str(value: str | None) -> str:
    if value is None:
        raise AssertionError("a required choice was not read")
    return value


def read_race_file(path: str | Path) -> RaceDefinition:
    """Parse and check a race file (.yaml, .yml or .json)."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8")
    except OSError as error:
        raise RaceFileError(f"{path}: cannot read: {error.strerror or error}") from None
    try:
        data = json.loads(text) if path.suffix.lower() == ".json" else yaml.safe_load(text)
    except (json.JSONDecodeError, yaml.YAMLError) as error:
        raise RaceFileError(
            f"{path}: not valid {'JSON' if path.suffix.lower() == '.json' else 'YAML'}: {error}"
        ) from None
    stem = path.name.split(".")[0]
    default_name = re.sub(r"[^A-Za-z0-9-]+", "-", stem).strip("-")[:64] or "race"
    return parse_race(data, str(path), default_name)
