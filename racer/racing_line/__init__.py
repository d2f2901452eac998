"""The car's fastest line round a track and its speed profile."""

from racer.racing_line.lap_time_bound import (
    CarLimits,
    LapTimeBoundError,
    RacingLine,
    path_speeds,
    profile_name,
    racing_line,
    standing_start_laps,
)

__all__ = [
    "CarLimits",
    "LapTimeBoundError",
    "RacingLine",
    "path_speeds",
    "profile_name",
    "racing_line",
    "standing_start_laps",
]
