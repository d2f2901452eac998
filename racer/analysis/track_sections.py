"""The track for the pictures: loaded with racer.shared.sim.tracks.track, cut into equal-length sections."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd

from racer.analysis.loading import EPISODE_KEY
from racer.shared.sim.tracks.track import Track, TrackError


def load_track(name_or_path: str, tracks_dir: Path | None = None) -> Track:
    """A route by name (from `tracks_dir`, default tracks/) or by .npy path; TrackError names the file."""
    return Track.load(name_or_path, tracks_dir)


def waypoint_distance_m(track: Track) -> np.ndarray:
    """Distance along the centre line from waypoint 0 to each waypoint."""
    segment_m = np.hypot(*np.diff(track.center_line, axis=0).T)
    return np.concatenate([[0.0], np.cumsum(segment_m)])


def section_of_waypoint(track: Track, sections: int) -> np.ndarray:
    """Section number (0..sections-1) of every waypoint; sections are equal lengths of centre line."""
    distance_m = waypoint_distance_m(track)
    return np.minimum((distance_m / distance_m[-1] * sections).astype(int), sections - 1)


def reversed_episodes(steps: pd.DataFrame, track: Track, samples: int = 7) -> pd.Series:
    """Whether each episode was driven on the reversed route (REVERSE_DIR / ALTERNATE_DRIVING_DIRECTION).

    The simtrace does not say so, but its closest_waypoint indexes the route as driven: a few rows per episode are
    matched against the track in both directions, and the direction that explains more of them wins.
    """
    backwards = track.reversed()
    driving = steps[steps["episode_status"] == "in_progress"]
    verdicts = {}
    for key, rows in driving.groupby(EPISODE_KEY, sort=False):
        picked = rows.iloc[np.linspace(0, len(rows) - 1, min(samples, len(rows))).astype(int)]
        forward_hits = reverse_hits = 0
        for x, y, logged in picked[["X", "Y", "closest_waypoint"]].itertuples(index=False, name=None):
            forward_hits += track.closest_waypoint_for_simtrace(x, y) == logged
            reverse_hits += backwards.closest_waypoint_for_simtrace(x, y) == logged
        verdicts[key] = reverse_hits > forward_hits
    index = pd.MultiIndex.from_tuples(list(verdicts), names=EPISODE_KEY) if verdicts else None
    return pd.Series(list(verdicts.values()), index=index, dtype=bool, name="reversed")


def forward_waypoint(steps: pd.DataFrame, reversed_by_episode: pd.Series, track: Track) -> pd.Series:
    """closest_waypoint as an index into the route file's order, whichever way each episode was driven."""
    reversed_rows = steps.join(reversed_by_episode, on=EPISODE_KEY)["reversed"].fillna(False).astype(bool)
    last = len(track.center_line) - 1
    return steps["closest_waypoint"].where(~reversed_rows, last - steps["closest_waypoint"])


__all__ = [
    "Track",
    "TrackError",
    "forward_waypoint",
    "load_track",
    "reversed_episodes",
    "section_of_waypoint",
    "waypoint_distance_m",
]
