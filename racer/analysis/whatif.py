"""Reward what-if: run a candidate reward_function.py over logged training steps and compare with the logged reward.

Params are rebuilt from each simtrace row and the track with the simulator's own `make_reward_params`, so the
candidate sees what it would have seen in training (x, y = front of car; speed and steering = the commanded action).
What a row cannot tell is filled with DeepRacer's defaults: no objects, the track's direction, and the simtrace
`episode_status` for is_offtrack / is_crashed. Rows are replayed in logged order because reward functions may keep
module-level state; as in DeepRacer, `prepare` and `pause` rows get reward 0 without calling the function.
`sim_time` is the clock when the step's observation arrived, before its physics: the previous row's `tstamp`
(a row's own `tstamp` is stamped after the physics).
"""

from __future__ import annotations

import sys
from pathlib import Path

import click
import numpy as np
import pandas as pd

from racer.analysis import aggregate
from racer.analysis.loading import EPISODE_KEY
from racer.analysis.sources import TRAINING
from racer.shared.sim.reward.function import load_reward_function
from racer.shared.sim.reward.params import make_reward_params
from racer.shared.sim.tracks.track import Track

NOT_CALLED_STATUSES = ("prepare", "pause")


def replay_reward(
    steps: pd.DataFrame,
    track: Track,
    reward_path: str | Path,
    *,
    reversed_by_episode: pd.Series | None = None,
    show_progress: bool = True,
) -> pd.Series:
    """The candidate's reward for every training step (index aligned with `steps`).

    Episodes marked in `reversed_by_episode` (track_sections.reversed_episodes) see the reversed route, as in
    DeepRacer (waypoints, closest_waypoints, is_reversed follow the driving direction).
    """
    reward_function = load_reward_function(reward_path)
    training = steps[steps["phase"] == TRAINING]
    if reversed_by_episode is not None:
        is_reversed = training.join(reversed_by_episode, on=EPISODE_KEY)["reversed"].fillna(False).astype(bool)
    else:
        is_reversed = pd.Series(False, index=training.index)
    tracks = {False: track, True: track.reversed() if is_reversed.any() else track}
    columns = [
        "X",
        "Y",
        "yaw",
        "throttle",
        "steer",
        "steps",
        "progress",
        "all_wheels_on_track",
        "episode_status",
        "tstamp",
    ]
    new_reward = np.zeros(len(training))
    total = len(training)
    observed_at_s = steps.groupby("file", sort=False)["tstamp"].shift(1).loc[training.index]
    observed_at_s = observed_at_s.fillna(training["tstamp"]).to_numpy()
    rows = zip(training[columns].itertuples(index=False, name=None), is_reversed.to_numpy(), observed_at_s, strict=True)
    bar = click.progressbar(
        rows,
        length=total,
        label=f"reward what-if over {total} steps",
        hidden=not show_progress,
        file=sys.stderr,
        update_min_steps=1000,
    )
    with bar:
        for position, (row, backwards, sim_time_s) in enumerate(bar):
            new_reward[position] = _replayed_reward(reward_function, tracks[bool(backwards)], row, sim_time_s)
    return pd.Series(new_reward, index=training.index, name="new_reward")


def _replayed_reward(reward_function, track: Track, row: tuple, sim_time_s: float) -> float:
    """The candidate's reward for one logged step (0 without a call on `prepare` and `pause` rows)."""
    x, y, yaw, throttle, steer, step, progress, on_track, status, _tstamp = row
    if status in NOT_CALLED_STATUSES:
        return 0.0
    params = make_reward_params(
        track,
        x=x,
        y=y,
        heading_deg=yaw,
        speed_mps=throttle,
        steering_angle_deg=steer,
        steps=step,
        progress=progress,
        all_wheels_on_track=bool(on_track),
        is_offtrack=status == "off_track",
        is_crashed=status == "crashed",
        sim_time_s=sim_time_s,
    )
    return reward_function(params)


def compare(
    steps: pd.DataFrame, new_reward: pd.Series, episode_table: pd.DataFrame
) -> tuple[pd.DataFrame, pd.DataFrame]:
    """(episodes with logged and new reward totals, per-iteration summary with their correlation)."""
    replayed = steps.loc[new_reward.index].assign(new_reward=new_reward)
    totals = replayed.groupby(EPISODE_KEY, sort=False)["new_reward"].sum().rename("new_reward").reset_index()
    episodes = episode_table.merge(totals, on=EPISODE_KEY, how="inner")
    by_iteration = episodes.groupby(["run", "iteration"]).agg(
        episodes=("episode", "size"),
        reward_mean=("reward", "mean"),
        new_reward_mean=("new_reward", "mean"),
        progress_mean_pct=("progress_pct", "mean"),
    )
    by_iteration["episode_reward_correlation"] = episodes.groupby(["run", "iteration"])[["reward", "new_reward"]].apply(
        lambda group: group["reward"].corr(group["new_reward"])
    )
    return episodes, by_iteration.reset_index()


def lap_steps(steps: pd.DataFrame, new_reward: pd.Series, episode_table: pd.DataFrame) -> pd.DataFrame:
    """The steps, with both rewards, of the fastest complete replayed lap (or the furthest replayed episode)."""
    replayed = steps.loc[new_reward.index].assign(new_reward=new_reward)
    candidates = episode_table.merge(replayed[EPISODE_KEY].drop_duplicates(), on=EPISODE_KEY)
    best = aggregate.best_laps(candidates, TRAINING, 1).iloc[0]
    chosen = (replayed[EPISODE_KEY] == best[EPISODE_KEY].to_numpy()).all(axis=1)
    return replayed[chosen]
