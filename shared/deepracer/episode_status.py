"""The episode status DeepRacer writes in each simtrace row (`episode_status`) and counts in the metrics files.

One enum for the whole system: the simulator's reset rules produce it, the simtrace and the metrics files write it.
A StrEnum, so a status equals its simtrace string (`EpisodeStatus.OFF_TRACK == "off_track"`).
"""

from __future__ import annotations

import enum


class EpisodeStatus(enum.StrEnum):
    """The simtrace `episode_status` strings; `.label` is the wording used in the metrics JSON files."""

    PREPARE = "prepare"
    IN_PROGRESS = "in_progress"
    OFF_TRACK = "off_track"
    LAP_COMPLETE = "lap_complete"
    CRASHED = "crashed"
    IMMOBILIZED = "immobilized"
    REVERSED = "reversed"
    PAUSE = "pause"
    PARK = "park"
    TIME_UP = "time_up"

    @property
    def label(self) -> str:
        return _LABELS[self]

    @property
    def ends_episode(self) -> bool:
        """True for the statuses a reset rule produces (the episode ends or pauses for a penalty)."""
        return self in _TERMINAL

    @classmethod
    def from_label(cls, label: str) -> EpisodeStatus:
        """The status for a metrics label such as "Lap complete"; ValueError naming the allowed labels otherwise."""
        for status, text in _LABELS.items():
            if text == label:
                return status
        raise ValueError(f"{label!r} is not an episode status label; allowed: {', '.join(_LABELS.values())}")


_LABELS: dict[EpisodeStatus, str] = {
    EpisodeStatus.PREPARE: "Prepare",
    EpisodeStatus.IN_PROGRESS: "In progress",
    EpisodeStatus.OFF_TRACK: "Off track",
    EpisodeStatus.LAP_COMPLETE: "Lap complete",
    EpisodeStatus.CRASHED: "Crashed",
    EpisodeStatus.IMMOBILIZED: "Immobilized",
    EpisodeStatus.REVERSED: "Reversed",
    EpisodeStatus.PAUSE: "Pause",
    EpisodeStatus.PARK: "Park",
    EpisodeStatus.TIME_UP: "Time Up",
}
_TERMINAL = frozenset(
    {
        EpisodeStatus.OFF_TRACK,
        EpisodeStatus.LAP_COMPLETE,
        EpisodeStatus.CRASHED,
        EpisodeStatus.IMMOBILIZED,
        EpisodeStatus.REVERSED,
        EpisodeStatus.TIME_UP,
    }
)
