"""Fixed-seed episodes through every branch of `DeepRacerEnv.step`'s episode phases, row by row.

Each scenario plays prepare, run and pause steps with the SimApp's penalties, resets and respawns, a lap, crashes
into boxes and bot cars (with their priorities) and a continuous action space, and asserts what DeepRacer's rules say
of its rows. `python -m tests.sim.test_env_characterisation` prints one digest per scenario of every simtrace row,
reward, reward params and observation: run it before and after reworking the env to show nothing changed.
"""

from __future__ import annotations

import hashlib
import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
import pytest

from racer.shared.deepracer.model_metadata import parse_model_metadata
from racer.shared.deepracer.simtrace import SIMTRACE_COLUMNS
from racer.shared.sim.config import EnvConfig
from racer.shared.sim.env import DeepRacerEnv
from racer.shared.sim.objects.challenge import ChallengeConfig, ObjectPosition
from tests.sim.conftest import place_far_off_track, place_front_at

STRAIGHT = 2  # default metadata: steering 0°, 1 m/s
HARD_LEFT = 9  # 30° at 2 m/s
STEP_S = 1.0 / 15
WALL_CLOCK = 1700000000.0


@dataclass(frozen=True)
class Step:
    """What one `step()` returned (or one `reset()`: `row` None)."""

    row: dict[str, Any] | None
    reward: float
    terminated: bool
    truncated: bool
    info: dict[str, Any]
    observation: dict[str, np.ndarray]
    objects: tuple[tuple[str, float, float, float], ...]
    """Every obstacle and bot car after the step."""

    @property
    def status(self) -> str:
        return self.info["episode_status"]


class Player:
    """Drives one env and keeps everything it returned."""

    def __init__(self, env: DeepRacerEnv) -> None:
        self.env = env
        self.steps: list[Step] = []

    def reset(self, **kwargs: Any) -> Step:
        observation, info = self.env.reset(**kwargs)
        self.steps.append(Step(None, 0.0, False, False, info, observation, self._objects()))
        return self.steps[-1]

    def step(self, action: Any) -> Step:
        observation, reward, terminated, truncated, info = self.env.step(action)
        self.steps.append(Step(info["simtrace"], reward, terminated, truncated, info, observation, self._objects()))
        return self.steps[-1]

    def _objects(self) -> tuple[tuple[str, float, float, float], ...]:
        return tuple((o.name, o.x_m, o.y_m, o.yaw_rad) for o in self.env.object_poses)

    def until(self, action: Callable[[], Any], stop: Callable[[Step], bool], limit: int = 200) -> Step:
        """Step until `stop` holds for a row (or the episode ends); the limit guards against a scenario gone wrong."""
        for _ in range(limit):
            step = self.step(action())
            if stop(step) or step.terminated or step.truncated:
                return step
        raise AssertionError(f"no stop condition within {limit} steps")

    def rows(self) -> list[dict[str, Any]]:
        return [s.row for s in self.steps if s.row is not None]


def _env(**overrides: Any) -> DeepRacerEnv:
    return DeepRacerEnv(EnvConfig(**overrides), wall_clock=lambda: WALL_CLOCK)


def _play(scenario: Callable[[Player], None], **overrides: Any) -> Player:
    env = _env(**overrides)
    try:
        player = Player(env)
        scenario(player)
        return player
    finally:
        env.close()


def _random_discrete(seed: int, n: int = 10) -> Callable[[], int]:
    rng = np.random.default_rng(seed)
    return lambda: int(rng.integers(n))


# ----- scenarios -------------------------------------------------------------------------------------------------


def time_trial_with_resets(p: Player) -> None:
    """Off-track, immobilized and reversed, each with a reset and its pause, then an off-track with none left."""
    p.reset(seed=11)
    drive = _random_discrete(11)
    p.step(STRAIGHT)  # prepare
    for _ in range(6):
        p.step(drive())
    place_far_off_track(p.env)
    p.until(drive, lambda s: s.status == "in_progress")  # off_track, its pause rows, back on the road

    def stand_still() -> int:
        place_front_at(p.env, 0.4)
        return STRAIGHT

    p.until(stand_still, lambda s: s.status != "in_progress")
    p.until(drive, lambda s: s.status == "in_progress")  # immobilized: one pause row for its 0 s penalty
    place_front_at(p.env, 0.6, backwards=True)
    p.until(lambda: STRAIGHT, lambda s: s.status != "in_progress")  # reversed
    p.until(drive, lambda s: s.status == "in_progress")
    for _ in range(3):
        p.step(drive())
    place_far_off_track(p.env)
    p.until(drive, lambda s: False)  # no reset left: the off-track ends the episode


def where_it_left(p: Player) -> None:
    """The summit rule's respawn: driven off the road by a hard turn, back on the centre line where it left."""
    p.reset(seed=3)
    p.until(lambda: HARD_LEFT, lambda s: s.status == "off_track")
    p.until(lambda: STRAIGHT, lambda s: s.status == "in_progress")
    p.until(lambda: HARD_LEFT, lambda s: False)


def laps(p: Player) -> None:
    """A training lap, an evaluation lap from mid-route continued across the line, the next training start."""
    p.reset(seed=5)
    p.step(STRAIGHT)
    for ndist in (*np.arange(0.05, 1.0, 0.05), 0.995, 0.004):
        place_front_at(p.env, float(ndist))
        p.step(STRAIGHT)
    p.reset(options={"evaluation": True, "start_ndist": 0.5})
    p.step(STRAIGHT)
    for ndist in (*np.arange(0.55, 1.5, 0.05), 1.495, 1.504):
        place_front_at(p.env, float(ndist) % 1.0)
        if p.step(STRAIGHT).terminated:
            break
    lap_end_s = p.steps[-1].row["tstamp"]
    p.env.continue_after_lap(lap_end_s, renew_reset_budget=True)
    for _ in range(4):
        p.step(STRAIGHT)
    place_far_off_track(p.env)
    p.until(lambda: STRAIGHT, lambda s: False)
    p.reset()
    for _ in range(3):
        p.step(STRAIGHT)


CONTINUOUS = parse_model_metadata(
    {
        "action_space": {"steering_angle": {"low": -25.0, "high": 30.0}, "speed": {"low": 0.6, "high": 2.5}},
        "action_space_type": "continuous",
        "sensor": ["FRONT_FACING_CAMERA"],
        "version": "5",
    },
    source="characterisation",
)


def continuous(p: Player) -> None:
    """Random continuous actions until the step cap truncates the episode (resets keep it going)."""
    p.reset(seed=8)
    rng = np.random.default_rng(8)
    p.until(lambda: rng.uniform(-1.2, 1.2, size=2).astype(np.float32), lambda s: False)


BOXES = ChallengeConfig(
    race_type="OBJECT_AVOIDANCE",
    object_positions=(ObjectPosition(0.0, -1), ObjectPosition(0.1, 1), ObjectPosition(0.5, -1)),
    enable_mercy_reset=True,
    max_resets_after_crash=2,
)


def boxes(p: Player) -> None:
    """Driven into a box, crashes at one box until the mercy reset, an off-track beside a box, a crash on the line."""
    p.reset(seed=7)
    p.until(lambda: STRAIGHT, lambda s: s.status == "crashed")  # box 1, across the line, still touches the start
    p.until(lambda: STRAIGHT, lambda s: s.status == "in_progress")
    p.until(lambda: STRAIGHT, lambda s: s.status == "crashed", limit=40)  # driven into box 2
    p.until(lambda: STRAIGHT, lambda s: s.status == "in_progress")
    box = p.env.object_poses[2]
    for _ in range(2):
        place_front_at(p.env, 0.45)
        p.step(STRAIGHT)
        p.env.teleport(box.x_m - 0.35 * math.cos(box.yaw_rad), box.y_m - 0.35 * math.sin(box.yaw_rad), box.yaw_rad)
        p.until(lambda: STRAIGHT, lambda s: s.status == "crashed")
        p.until(lambda: STRAIGHT, lambda s: s.status == "in_progress")
    place_front_at(p.env, 0.47)
    p.step(STRAIGHT)
    place_far_off_track(p.env)
    p.until(lambda: STRAIGHT, lambda s: s.status == "in_progress")  # reset behind box 3 on the other lane
    for ndist in (0.7, 0.8, 0.9, 0.97):
        place_front_at(p.env, ndist)
        p.step(STRAIGHT)
    first = p.env.object_poses[0]
    c, s = math.cos(first.yaw_rad), math.sin(first.yaw_rad)
    p.env.teleport(first.x_m + 0.05 * c, first.y_m + 0.05 * s, first.yaw_rad)  # across the line, inside box 1
    p.step(STRAIGHT)


def bot_cars(p: Player) -> None:
    """Bots changing lanes, one running into the car from behind, the car running into one, until no reset is left."""
    p.reset(seed=9)
    drive = _random_discrete(9, 3)
    for _ in range(8):
        p.step(drive())
    bot = p.env.object_poses[0]
    c, s = math.cos(bot.yaw_rad), math.sin(bot.yaw_rad)
    p.env.teleport(bot.x_m + 0.3 * c, bot.y_m + 0.3 * s, bot.yaw_rad)
    p.step(0)
    p.step(0)
    for _ in range(3):
        bot = p.env.object_poses[1]
        c, s = math.cos(bot.yaw_rad), math.sin(bot.yaw_rad)
        p.env.teleport(bot.x_m - 0.3 * c, bot.y_m - 0.3 * s, bot.yaw_rad)
        if p.until(drive, lambda s: s.status == "in_progress", limit=30).terminated:
            break
        for _ in range(4):
            p.step(drive())


BOTS = ChallengeConfig(
    race_type="HEAD_TO_BOT",
    number_of_bot_cars=2,
    bot_car_speed_mps=0.5,
    is_lane_change=True,
    lower_lane_change_time_s=0.5,
    upper_lane_change_time_s=1.0,
    penalty_seconds=0.5,
)
LIDAR_METADATA = parse_model_metadata(
    {
        "action_space": [
            {"steering_angle": 0.0, "speed": 1.0},
            {"steering_angle": 20.0, "speed": 1.5},
            {"steering_angle": -20.0, "speed": 0.8},
        ],
        "sensor": ["FRONT_FACING_CAMERA", "LIDAR"],
        "version": "5",
    },
    source="characterisation",
)

SCENARIOS: dict[str, tuple[Callable[[Player], None], dict[str, Any]]] = {
    "time_trial_with_resets": (
        time_trial_with_resets,
        {"number_of_resets": 3, "off_track_penalty_s": 0.25, "immobilized_penalty_s": 0.0, "reverse_penalty_s": 0.1},
    ),
    "where_it_left": (where_it_left, {"number_of_resets": 1, "reset_position": "where_it_left"}),
    "laps": (laps, {"number_of_resets": 1}),
    "continuous": (continuous, {"model_metadata": CONTINUOUS, "max_steps": 40, "number_of_resets": 5}),
    "boxes": (
        boxes,
        {"challenge": BOXES, "number_of_resets": 6, "collision_penalty_s": 0.3, "change_start_position": False},
    ),
    "bot_cars": (
        bot_cars,
        {"challenge": BOTS, "model_metadata": LIDAR_METADATA, "number_of_resets": 2, "collision_penalty_s": 0.2},
    ),
}


def play(name: str) -> Player:
    scenario, overrides = SCENARIOS[name]
    return _play(scenario, **overrides)


def digest(player: Player) -> str:
    """SHA-256 of everything the env returned, floats by their exact repr, observations by their bytes."""
    h = hashlib.sha256()
    for step in player.steps:
        info = {k: v for k, v in step.info.items() if k not in ("simtrace", "params")}
        params = sorted(step.info.get("params", {}).items())
        everything = (
            step.row,
            step.reward,
            step.terminated,
            step.truncated,
            sorted(info.items()),
            params,
            step.objects,
        )
        h.update(repr(everything).encode())
        for key in sorted(step.observation):
            h.update(key.encode())
            h.update(np.ascontiguousarray(step.observation[key]).tobytes())
    return h.hexdigest()


# ----- what the rows must show -----------------------------------------------------------------------------------


def _runs(rows: list[dict[str, Any]]) -> list[str]:
    """The statuses with repeats collapsed."""
    out: list[str] = []
    for row in rows:
        if not out or out[-1] != row["episode_status"]:
            out.append(row["episode_status"])
    return out


def _assert_rows_are_consistent(player: Player) -> None:
    """Every row: the 19 columns in order, steps counting up per episode, 1/15 s apart, reward 0 unless a RUN step."""
    previous: dict[str, Any] | None = None
    for step in player.steps:
        if step.row is None:
            previous = None
            continue
        row = step.row
        assert list(row) == list(SIMTRACE_COLUMNS)
        assert row["reward"] == step.reward and row["done"] == (step.terminated or step.truncated)
        assert row["wall_clock"] == WALL_CLOCK
        if row["episode_status"] in ("prepare", "pause"):
            assert step.reward == 0.0
        if previous is not None:
            assert row["steps"] == previous["steps"] + 1
            assert row["tstamp"] == pytest.approx(previous["tstamp"] + STEP_S, abs=1e-9)
        else:
            assert row["steps"] == 1
        previous = row


def _pauses(rows: list[dict[str, Any]]) -> list[list[float]]:
    """The pause_duration column of each run of pause rows."""
    groups: list[list[float]] = []
    for i, row in enumerate(rows):
        if row["episode_status"] == "pause":
            if i == 0 or rows[i - 1]["episode_status"] != "pause":
                groups.append([])
            groups[-1].append(row["pause_duration"])
    return groups


def _row_after_pause(rows: list[dict[str, Any]], steps: float) -> dict[str, Any]:
    """The first row after the pause that follows row `steps` of the (single) episode."""
    later = [r for r in rows if r["steps"] > steps]
    return next(r for i, r in enumerate(later) if i and later[i - 1]["episode_status"] == "pause")


def test_time_trial_resets_pause_for_each_penalty_until_none_is_left():
    player = play("time_trial_with_resets")
    _assert_rows_are_consistent(player)
    rows = player.rows()
    assert _runs(rows) == [
        "prepare",
        "in_progress",
        "off_track",
        "pause",
        "in_progress",
        "immobilized",
        "pause",
        "in_progress",
        "reversed",
        "pause",
        "in_progress",
        "off_track",
    ]
    assert rows[-1]["done"] and player.steps[-1].terminated
    off, immobilized, reversed_ = _pauses(rows)
    # The row that breaks a rule shows the whole penalty; the pause rows count down to what is left of it.
    assert [r["pause_duration"] for r in rows if r["episode_status"] in ("off_track", "reversed")][:2] == [0.25, 0.1]
    assert off == pytest.approx([0.25 - STEP_S * k for k in (1, 2, 3, 4)])  # 0.25 s: the last row shows -1/60 s
    assert immobilized == pytest.approx([-STEP_S])  # a 0 s penalty still spends one pause step
    assert reversed_ == pytest.approx([0.1 - STEP_S, 0.1 - 2 * STEP_S])
    assert [r["pause_duration"] for r in rows if r["episode_status"] == "in_progress"] == [0.0] * sum(
        r["episode_status"] == "in_progress" for r in rows
    )


def test_where_it_left_puts_the_car_back_on_the_centre_line_behind_where_it_left():
    player = play("where_it_left")
    _assert_rows_are_consistent(player)
    rows = player.rows()
    assert _runs(rows) == ["prepare", "in_progress", "off_track", "pause", "in_progress", "off_track"]
    assert player.steps[-1].terminated
    back = next(i for i, r in enumerate(rows) if i and rows[i - 1]["episode_status"] == "pause")
    left = max(r["progress"] for r in rows[:back] if r["all_wheels_on_track"])
    assert left - 1.0 < rows[back]["progress"] < left  # half a step behind the last point with four wheels on
    assert player.steps[1 + back].info["params"]["distance_from_center"] < 0.02


def test_laps_end_at_the_line_and_an_evaluation_lap_continues_across_it():
    player = play("laps")
    _assert_rows_are_consistent(player)
    ends = [s for s in player.steps if s.row is not None and s.status == "lap_complete"]
    assert len(ends) == 2 and all(s.terminated and s.row["progress"] == 100 for s in ends)
    resets = [i for i, s in enumerate(player.steps) if s.row is None]
    starts_s = [player.steps[i].info["start_time_s"] for i in resets]
    assert ends[0].info["lap_time_s"] == pytest.approx(ends[0].row["tstamp"] - starts_s[0], abs=1e-9)
    assert ends[1].info["lap_time_s"] == pytest.approx(ends[1].row["tstamp"] - starts_s[1], abs=1e-9)
    assert player.steps[resets[1]].info["evaluation"] and player.steps[resets[1]].info["start_ndist"] == 0.5
    # After the crossing the evaluation goes on: progress from 0 again, its reset budget renewed (one reset).
    after = player.steps[player.steps.index(ends[1]) + 1 : resets[2]]
    assert after[0].status == "in_progress" and after[0].row["progress"] < 5
    assert after[-1].status == "off_track" and after[-1].terminated
    assert any(s.status == "pause" for s in after)
    # Only the training episode moved the next training start.
    assert player.steps[resets[2]].info["start_ndist"] == pytest.approx(0.05)
    assert player.steps[resets[2]].info["episode"] == 1


def test_continuous_actions_are_scaled_and_the_step_cap_truncates():
    player = play("continuous")
    _assert_rows_are_consistent(player)
    rows = player.rows()
    assert len(rows) == 40 and player.steps[-1].truncated and not player.steps[-1].terminated
    assert all(r["action"] == f"[{r['steer']} {r['throttle']}]" for r in rows)
    assert all(-25.0 <= r["steer"] <= 30.0 and 0.6 <= r["throttle"] <= 2.5 for r in rows)
    assert {r["steer"] for r in rows} >= {-25.0, 30.0}  # beyond [-1, 1]: clipped to the ends


def test_box_crashes_reset_behind_the_box_until_the_mercy_reset_and_a_crash_on_the_line_completes_the_lap():
    player = play("boxes")
    _assert_rows_are_consistent(player)
    rows = player.rows()
    crashes = [s for s in player.steps if s.row is not None and s.status == "crashed"]
    assert len(crashes) == 5 and all(s.info["params"]["is_crashed"] for s in crashes)
    assert [s.row["pause_duration"] for s in crashes] == [0.3] * 5
    # Box 1 stands across the start line, where the SimApp's search does not look: the usual reset. Then two resets
    # behind box 2 (the second lands on box 1 and is the mercy one, ahead of box 2), two at box 3 (the second ahead).
    assert [s.row["obstacle_crash_counter"] for s in crashes] == [0, 1, 0, 1, 0]
    after_mercy = [_row_after_pause(rows, s.row["steps"])["progress"] for s in crashes[2::2]]
    assert after_mercy[0] > 100 * (1.35 + 1.0) / player.env.track.length_m  # RESET_AHEAD_DIST past box 2
    assert after_mercy[1] > 50.0  # past box 3
    assert "off_track" in _runs(rows)
    last = player.steps[-1]
    assert last.status == "lap_complete" and last.terminated and last.info["params"]["is_crashed"] is True
    assert len(last.info["params"]["objects_location"]) == 3
    assert len({s.objects for s in player.steps}) == 1  # static obstacles stay where they are


def test_bot_cars_a_bot_from_behind_is_no_crash_the_car_into_a_bot_is_until_no_reset_is_left():
    player = play("bot_cars")
    _assert_rows_are_consistent(player)
    rows = player.rows()
    hit_from_behind = player.steps[9]
    assert hit_from_behind.status == "in_progress" and hit_from_behind.info["params"]["is_crashed"] is False
    # The bots that ran into the car stand for PENALTY_SECONDS (0.5 s); before, they drove on.
    assert player.steps[7].objects != player.steps[8].objects
    assert len({s.objects for s in player.steps[8:13]}) == 1
    crashed = [s for s in player.steps if s.row and s.status == "crashed"]
    assert len(crashed) == 3 and crashed[-1].terminated and not any(s.terminated for s in crashed[:2])
    assert all(s.info["params"]["is_crashed"] for s in crashed)
    assert _runs(rows).count("pause") == 2
    assert all(s.observation["LIDAR"].shape == (64,) for s in player.steps)


if __name__ == "__main__":
    for scenario_name in SCENARIOS:
        played = play(scenario_name)
        print(f"{scenario_name:24s} {len(played.steps):4d} steps  {digest(played)}")
