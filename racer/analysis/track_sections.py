"""The track for the pictures: loaded with racer.shared.sim.track, cut into equal-length sections."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from racer.shared.sim.track import Track, TrackError


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


__all__ = ["Track", "TrackError", "load_track", "section_of_waypoint", "waypoint_distance_m"]
