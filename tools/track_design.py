"""The project's own tracks: periodic splines through hand-placed control points, written as DeepRacer route files.

Run `python -m tools.track_design [OUT_DIR]` to regenerate `tracks/*.npy`. The output is
deterministic. Rows are ordered counter-clockwise so that, as in DeepRacer's routes, "inner" is the left border.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.interpolate import CubicSpline
from shapely.geometry import LinearRing, Polygon

from racer.shared.sim.tracks.track import default_tracks_dir


@dataclass(frozen=True)
class TrackDesign:
    name: str
    control_points_m: tuple[tuple[float, float], ...]
    """Closed loop of (x, y) points the centre line passes through (the first is not repeated)."""
    width_m: float
    waypoint_spacing_m: float = 0.15
    description: str = ""


DESIGNS: tuple[TrackDesign, ...] = (
    TrackDesign(
        name="racer_oval",
        description="Quick-start default: a short, wide stadium oval (two straights, two 180° bends).",
        width_m=1.07,
        control_points_m=(
            (0.0, 0.0),
            (1.2, 0.0),
            (2.4, 0.0),
            (3.45, 0.22),
            (4.0, 1.1),
            (3.45, 1.98),
            (2.4, 2.2),
            (1.2, 2.2),
            (0.0, 2.2),
            (-1.05, 1.98),
            (-1.6, 1.1),
            (-1.05, 0.22),
        ),
    ),
    TrackDesign(
        name="racer_bean",
        description="A kidney shape: one long sweeper, a concave left-right section and a tight hairpin.",
        width_m=0.91,
        control_points_m=(
            (0.0, 0.0),
            (2.0, -0.3),
            (4.0, -0.2),
            (5.6, 0.6),
            (6.0, 2.0),
            (5.2, 3.3),
            (3.8, 3.5),
            (2.8, 2.7),
            (1.8, 2.4),
            (0.6, 3.2),
            (-0.8, 3.2),
            (-1.5, 2.0),
            (-1.2, 0.7),
        ),
    ),
    TrackDesign(
        name="racer_circuit",
        description="A longer technical circuit with a chicane, a hairpin and an S-bend; 30-inch road.",
        width_m=0.76,
        control_points_m=(
            (0.0, 0.0),
            (2.5, 0.0),
            (5.0, 0.0),
            (6.6, 0.4),
            (7.3, 1.6),
            (6.8, 2.8),
            (5.6, 3.1),
            (4.6, 3.8),
            (4.8, 5.0),
            (5.8, 5.6),
            (6.4, 6.8),
            (5.6, 7.8),
            (4.0, 7.8),
            (2.8, 6.9),
            (2.2, 5.6),
            (1.0, 5.0),
            (-0.4, 5.4),
            (-1.6, 5.0),
            (-2.0, 3.6),
            (-1.2, 2.6),
            (-1.6, 1.3),
            (-1.2, 0.3),
        ),
    ),
)


def centre_line(design: TrackDesign) -> np.ndarray:
    """Evenly spaced points (about `waypoint_spacing_m` apart) on the periodic spline, counter-clockwise."""
    points = np.asarray(design.control_points_m, dtype=np.float64)
    if not LinearRing(points).is_ccw:
        points = points[::-1]
    closed = np.vstack([points, points[:1]])
    chord = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(closed, axis=0), axis=1))])
    spline = CubicSpline(chord, closed, bc_type="periodic")
    dense_t = np.linspace(0.0, chord[-1], 20000)
    dense = spline(dense_t)
    arc = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(dense, axis=0), axis=1))])
    count = max(int(round(arc[-1] / design.waypoint_spacing_m)), 8)
    targets = np.linspace(0.0, arc[-1], count, endpoint=False)
    return spline(np.interp(targets, arc, dense_t))


def route_rows(design: TrackDesign) -> np.ndarray:
    """(N, 6) rows [centre, inner (left), outer (right)], closed (last row == first row)."""
    center = centre_line(design)
    tangent = np.roll(center, -1, axis=0) - np.roll(center, 1, axis=0)
    tangent /= np.linalg.norm(tangent, axis=1, keepdims=True)
    left = np.stack([-tangent[:, 1], tangent[:, 0]], axis=1)
    half = design.width_m / 2.0
    rows = np.hstack([center, center + left * half, center - left * half])
    rows = np.vstack([rows, rows[:1]])
    check_route(design.name, rows)
    return rows


def check_route(name: str, rows: np.ndarray) -> None:
    """The borders must form a valid ring-shaped road (no border crossing itself on tight bends)."""
    road = Polygon(rows[:, 4:6], [rows[:, 2:4]])
    for label, line in (("centre", rows[:, 0:2]), ("inner", rows[:, 2:4]), ("outer", rows[:, 4:6])):
        if not LinearRing(line).is_simple:
            raise ValueError(f"track {name}: the {label} line crosses itself; widen the bends or narrow the road")
    if not road.is_valid:
        raise ValueError(f"track {name}: the road polygon is invalid")


def write_tracks(out_dir: Path) -> list[Path]:
    out_dir.mkdir(parents=True, exist_ok=True)
    written = []
    for design in DESIGNS:
        path = out_dir / f"{design.name}.npy"
        np.save(path, route_rows(design).astype(np.float64))
        written.append(path)
    return written


def main(argv: list[str]) -> None:
    out_dir = Path(argv[0]) if argv else default_tracks_dir()
    for path in write_tracks(out_dir):
        rows = np.load(path)
        print(f"{path}: {len(rows)} rows, length {LinearRing(rows[:, 0:2]).length:.3f} m")


if __name__ == "__main__":
    main(sys.argv[1:])
