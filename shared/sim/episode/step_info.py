"""The `info` dict of one env step, with the step's simtrace row (the SimApp's 19 columns, in order)."""

from __future__ import annotations

from typing import Any

from racer.shared.sim.episode.phase import StepVerdict
from racer.shared.sim.sensors.spaces import ChosenAction


def step_info(
    params: dict[str, Any],
    verdict: StepVerdict,
    action: ChosenAction,
    *,
    episode: int,
    reward: float,
    done: bool,
    closest_waypoint: int,
    tstamp_s: float,
    obstacle_crash_counter: int,
    wall_clock_s: float,
    evaluation: bool,
    lap_time_s: float | None,
) -> dict[str, Any]:
    """`simtrace`, `params`, `episode_status`, `progress`, `evaluation` and, on a completed lap, `lap_time_s`.

    The row describes the judged pose as its reward `params` do (the reward function gets a copy of them).
    """
    simtrace = {
        "episode": episode,
        "steps": params["steps"],
        "X": params["x"],
        "Y": params["y"],
        "yaw": params["heading"],
        "steer": action.steering_deg,
        "throttle": action.speed_mps,
        "action": action.simtrace_field,
        "reward": reward,
        "done": done,
        "all_wheels_on_track": params["all_wheels_on_track"],
        "progress": verdict.progress,
        "closest_waypoint": closest_waypoint,
        "track_len": params["track_length"],
        "tstamp": tstamp_s,
        "episode_status": verdict.status,
        "pause_duration": verdict.pause_duration_s,
        "obstacle_crash_counter": obstacle_crash_counter,
        "wall_clock": wall_clock_s,
    }
    info: dict[str, Any] = {
        "simtrace": simtrace,
        "params": params,
        "episode_status": verdict.status,
        "progress": verdict.progress,
        "evaluation": evaluation,
    }
    if lap_time_s is not None:
        info["lap_time_s"] = lap_time_s
    return info
