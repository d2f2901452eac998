"""A line's files for users: `line.csv` and `line.npy` (one row per station), `line.json` (its laps and what it is of).

The columns are x, y, speed_mps, time_s, curvature_per_m, distance_m in DeepRacer's route coordinates (metres, the
route file's frame); the first four are the community's racing-line layout (x, y, speed, time). As in a DeepRacer
route file of a loop, the last row repeats the first station, so time_s ends at the flying lap and distance_m at the
line's length.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from racer.racing_line.line import RacingLine

COLUMNS: tuple[str, ...] = ("x", "y", "speed_mps", "time_s", "curvature_per_m", "distance_m")
CSV_FILE = "line.csv"
NPY_FILE = "line.npy"
JSON_FILE = "line.json"
PNG_FILE = "line.png"


@dataclass(frozen=True)
class LineAbout:
    """What a line is of, for line.json: the track and the car as the user named them, and the route file's hash."""

    track: str
    direction: str
    generation: str
    car_profile: str
    world: str
    route_sha256: str


def line_table(line: RacingLine) -> np.ndarray:
    """(N + 1, 6) the line's stations in COLUMNS order, station 0 repeated at the end (at the lap's time and length)."""
    closed = np.arange(len(line.speeds_mps) + 1) % len(line.speeds_mps)
    return np.column_stack(
        (
            line.points_m[closed],
            line.speeds_mps[closed],
            line.times_s,
            line.curvatures_per_m[closed],
            line.distances_m,
        )
    )


def line_facts(line: RacingLine, about: LineAbout) -> dict:
    """line.json's content: the laps, the line, its braking points and what it is of."""
    table = line_table(line)
    braking = line.braking_indices
    return {
        "track": about.track,
        "direction": about.direction,
        "generation": about.generation,
        "car_profile": about.car_profile,
        "world": about.world,
        "route_sha256": about.route_sha256,
        "flying_lap_s": round(line.lap_time_s, 4),
        "standing_start_laps_s": [round(t, 4) for t in line.standing_laps_s],
        "three_lap_average_s": round(line.standing_average_s, 4),
        "centre_line_lap_s": round(line.centre_line_lap_time_s, 4),
        "line_length_m": round(line.length_m, 4),
        "top_speed_mps": round(float(line.speeds_mps.max()), 4),
        "lowest_speed_mps": round(float(line.speeds_mps.min()), 4),
        "braking_points": [
            {
                "x": round(float(table[i, 0]), 4),
                "y": round(float(table[i, 1]), 4),
                "distance_m": round(float(table[i, 5]), 4),
                "speed_mps": round(float(table[i, 2]), 4),
            }
            for i in braking
        ],
        "min_clearance_m": round(line.min_clearance_m, 4),
        "max_curvature_per_m": round(line.max_curvature_per_m, 4),
        "stations": int(table.shape[0]),
        "columns": list(COLUMNS),
        "optimiser_iterations": line.optimiser_iterations,
        "car": line.limits.summary(),
    }


def write_line_files(line: RacingLine, about: LineAbout, folder: Path) -> dict[str, Path]:
    """line.csv, line.npy and line.json in `folder` (made if missing); the paths by file name."""
    folder.mkdir(parents=True, exist_ok=True)
    table = line_table(line)
    paths = {name: folder / name for name in (CSV_FILE, NPY_FILE, JSON_FILE)}
    np.savetxt(paths[CSV_FILE], table, fmt="%.6f", delimiter=",", header=",".join(COLUMNS), comments="")
    np.save(paths[NPY_FILE], table, allow_pickle=False)
    paths[JSON_FILE].write_text(json.dumps(line_facts(line, about), indent=2) + "\n")
    return paths
