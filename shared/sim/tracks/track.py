"""DeepRacer route files and the exact track geometry the reward params are built from.

A route is a `.npy` float64 array of shape (N, 6): centre x, y, inner border x, y, outer border x, y (metres).
It is a loop when the first row equals the last row, otherwise an open track.

DeepRacer computes everything with shapely/GEOS (`LinearRing.project`, `interpolate`, `Polygon.contains`).
Projection is on the hot path of every env step: `polyline.py` re-implements it in numpy, GEOS-identical.
Containment uses shapely's prepared polygon directly (that is already fast).
"""

from __future__ import annotations

import bisect
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import shapely
from shapely.geometry import LinearRing, LineString, Polygon

from racer.shared.sim.tracks.polyline import BorderPair, Polyline
from racer.shared.sim.tracks.route_search import (
    ROUTE_SUFFIX,
    RouteNotFoundError,
    available_routes,
    default_tracks_dir,
    find_route,
    is_route_name,
    search_folders,
)

__all__ = [
    "ROUTE_SUFFIX",
    "PointGeometry",
    "Track",
    "TrackError",
    "available_tracks",
    "compute_progress",
    "default_tracks_dir",
    "read_route_file",
]


class TrackError(ValueError):
    """A route file is missing or malformed; the message names the file and the problem."""


def available_tracks(tracks_dir: Path | None = None) -> list[str]:
    """Names of the route files in a tracks directory, or on the route search path (None), sorted."""
    return available_routes([Path(tracks_dir)] if tracks_dir is not None else search_folders())


@dataclass(frozen=True)
class PointGeometry:
    """Everything DeepRacer derives from one point's projection on the centre line (one projection pass)."""

    ndist: float
    """Normalised projection on the centre line, [0, 1]."""
    distance_from_center_m: float
    track_width_m: float
    is_left_of_center: bool
    closest_waypoints: tuple[int, int]
    closest_waypoint_for_simtrace: int


class Track:
    """A route in one driving direction, with DeepRacer's geometry definitions (deepracer-simapp v5.3.3
    `bundle/markov/track_geom/track_data.py`)."""

    def __init__(self, name: str, waypoints: np.ndarray, *, direction_reversed: bool = False, source: str = "") -> None:
        self.name = name
        self.source = source or name
        self.waypoints = waypoints
        self.direction_reversed = direction_reversed
        self.is_loop = bool(np.array_equal(waypoints[0], waypoints[-1]))
        self.center_line = np.ascontiguousarray(waypoints[:, 0:2])
        self.inner_border = np.ascontiguousarray(waypoints[:, 2:4])
        self.outer_border = np.ascontiguousarray(waypoints[:, 4:6])
        self._center = Polyline(self.center_line)
        self._inner = Polyline(self.inner_border)
        self._outer = Polyline(self.outer_border)
        self._borders = BorderPair(self._inner, self._outer)
        self._inner_polygon: Polygon | None = None
        line_cls = LinearRing if self.is_loop else LineString
        self.length_m = float(line_cls(self.center_line).length)
        if self.is_loop:
            self.road_polygon = Polygon(self.outer_border, [self.inner_border])
        else:
            self.road_polygon = Polygon(np.vstack((self.outer_border, self.inner_border[::-1])))
        if not self.road_polygon.is_valid:
            raise TrackError(
                f"{self.source}: the borders do not form a valid road polygon ({shapely.is_valid_reason(self.road_polygon)})"
            )
        shapely.prepare(self.road_polygon)
        # DeepRacer's waypoint projections: coords[:-1] projected on the line, then 1.0 for the last one.
        self._waypoint_ndists = [self._center.project(x, y) / self._center.length for x, y in self.center_line[:-1]]
        self._waypoint_ndists.append(1.0)
        self._waypoint_tuples = [(float(x), float(y)) for x, y in self.center_line]
        # The orientation of the driven direction: ring orientation of the rows as stored here. An open route has no
        # ring orientation; the SimApp takes it as counter-clockwise driven forward (track_data.py), so the flag is
        # True forward and False reversed.
        self._is_ccw = bool(LinearRing(self.center_line).is_ccw) if self.is_loop else not direction_reversed

    def __repr__(self) -> str:
        direction = "reversed" if self.direction_reversed else "forward"
        return f"Track({self.name!r}, {self.num_waypoints} waypoints, {self.length_m:.3f} m, {direction})"

    # ----- loading -------------------------------------------------------------------------------------------

    @classmethod
    def load(cls, name_or_path: str | Path, tracks_dir: str | Path | None = None) -> Track:
        """Load a route from a `.npy` path, or by name (WORLD_NAME, without suffix) from `tracks_dir`, or, when that
        is None, from the route search path (RACER_ROUTES_PATH's folders, then racer's `tracks/`)."""
        if not is_route_name(name_or_path):
            path = Path(name_or_path)
        else:
            folders = [Path(tracks_dir)] if tracks_dir is not None else None
            try:
                path = find_route(str(name_or_path), folders)
            except RouteNotFoundError as error:
                raise TrackError(str(error)) from None
        return cls(path.stem, read_route_file(path), source=str(path))

    def reversed(self) -> Track:
        """The same route driven the other way (REVERSE_DIR / alternate direction): rows reversed."""
        return Track(
            self.name, self.waypoints[::-1].copy(), direction_reversed=not self.direction_reversed, source=self.source
        )

    @property
    def is_ccw(self) -> bool:
        """Whether the driving direction is counter-clockwise (DeepRacer: ring orientation XOR reverse flag)."""
        return self._is_ccw

    @property
    def waypoint_tuples(self) -> list[tuple[float, float]]:
        """`params['waypoints']`: the centre line as (x, y) tuples in the driving direction (a fresh list)."""
        return list(self._waypoint_tuples)

    @property
    def num_waypoints(self) -> int:
        return len(self.center_line)

    # ----- geometry on a point -------------------------------------------------------------------------------

    @property
    def center_segments(self) -> Polyline:
        """The centre line's segment arrays (for searches that reuse its arithmetic, `moving_projection.py`)."""
        return self._center

    def project_normalized(self, x: float, y: float) -> float:
        """`center_line.project(point, normalized=True)`."""
        return self._center.project(x, y) / self._center.length

    def project_m(self, x: float, y: float) -> float:
        """`center_line.project(point)`: metres along the centre line from the route's first row."""
        return self._center.project(x, y)

    def project_points_m(self, xs: np.ndarray, ys: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """`project_m` of several points at once, with their nearest centre-line points: (metres along the centre
        line, nearest xs, nearest ys); the same values as the one-point methods."""
        return self._center.project_many(np.asarray(xs, dtype=np.float64), np.asarray(ys, dtype=np.float64))

    def in_inner_polygon(self, x: float, y: float) -> bool:
        """Strictly inside `Polygon(center_line, [inner_border])` (the SimApp's objects_left_of_center test). Loops
        only."""
        return bool(shapely.contains_xy(self._prepared_inner_polygon(), x, y))

    def in_inner_polygon_points(self, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
        """`in_inner_polygon` of several points at once (one shapely call)."""
        return np.asarray(shapely.contains_xy(self._prepared_inner_polygon(), xs, ys), dtype=bool)

    def _prepared_inner_polygon(self) -> Polygon:
        """Built once, on first use."""
        if self._inner_polygon is None:
            self._inner_polygon = Polygon(self.center_line, [self.inner_border])
            shapely.prepare(self._inner_polygon)
        return self._inner_polygon

    def distance_from_center(self, x: float, y: float) -> float:
        cx, cy = self._center.nearest_point(x, y)
        return math.hypot(x - cx, y - cy)

    def closest_waypoints(self, x: float, y: float) -> tuple[int, int]:
        """(prev, next) waypoint indices bracketing the point's projection (DeepRacer `find_prev_next`)."""
        return self._prev_next(self.project_normalized(x, y))

    def closest_waypoint_for_simtrace(self, x: float, y: float) -> int:
        """Simtrace column `closest_waypoint`: whichever of (prev, next) is nearer to the point."""
        prev_idx, next_idx = self.closest_waypoints(x, y)
        return self._nearer_of(x, y, prev_idx, next_idx)

    def track_width_at(self, x: float, y: float) -> float:
        _, _, width = self._border_distances(*self._center.nearest_point(x, y), x, y)
        return width

    def is_left_of_center(self, x: float, y: float) -> bool:
        d_inner, d_outer, _ = self._border_distances(*self._center.nearest_point(x, y), x, y)
        return (d_inner < d_outer) ^ (not self.is_ccw)

    def contains(self, x: float, y: float) -> bool:
        """Strictly inside the road polygon (border points are outside)."""
        return bool(shapely.contains_xy(self.road_polygon, x, y))

    def contains_points(self, xs: np.ndarray, ys: np.ndarray) -> np.ndarray:
        """Vectorised `contains` (used for the four wheel centres)."""
        return np.asarray(shapely.contains_xy(self.road_polygon, xs, ys), dtype=bool)

    def point_geometry(self, x: float, y: float) -> PointGeometry:
        """All projection-derived quantities of a point with a single centre-line projection (the env's hot path)."""
        i, factor = self._center.locate(x, y)
        c = self._center
        measure = c.start_measure_list[i] if factor <= 0.0 else c.start_measure_list[i] + factor * c.seg_len_list[i]
        ndist = measure / c.length
        cx = c.ax_list[i] + factor * c.dx_list[i]
        cy = c.ay_list[i] + factor * c.dy_list[i]
        d_inner, d_outer, width = self._border_distances(cx, cy, x, y)
        prev_idx, next_idx = self._prev_next(ndist)
        return PointGeometry(
            ndist=ndist,
            distance_from_center_m=math.hypot(x - cx, y - cy),
            track_width_m=width,
            is_left_of_center=(d_inner < d_outer) ^ (not self.is_ccw),
            closest_waypoints=(prev_idx, next_idx),
            closest_waypoint_for_simtrace=self._nearer_of(x, y, prev_idx, next_idx),
        )

    # ----- positions along the line (start and reset poses) --------------------------------------------------

    def pose_at(self, ndist: float, lane: str = "center") -> tuple[float, float, float]:
        """(x, y, yaw_rad) at a normalised distance on the centre line or on the inner/outer lane.

        Yaw points from that point to the next waypoint, as DeepRacer's start pose. A lane is the line half-way
        between the centre line and a border.
        """
        if lane not in ("center", "inner", "outer"):
            raise ValueError(f"lane must be 'center', 'inner' or 'outer', got {lane!r}")
        ndist = ndist % 1.0 if self.is_loop else min(max(ndist, 0.0), 1.0)
        cx, cy = self._center.interpolate(ndist * self._center.length)
        _, next_idx = self._prev_next(ndist)
        nx, ny = self.center_line[next_idx]
        if lane != "center":
            border = self._inner if lane == "inner" else self._outer
            bx, by = border.nearest_point(cx, cy)
            cx, cy = (cx + bx) / 2.0, (cy + by) / 2.0
            nbx, nby = border.nearest_point(nx, ny)
            nx, ny = (nx + nbx) / 2.0, (ny + nby) / 2.0
        return cx, cy, math.atan2(ny - cy, nx - cx)

    def nearer_lane(self, x: float, y: float) -> str:
        """'inner' or 'outer': the lane on the side of the centre line the point is on (reset placement)."""
        d_inner, d_outer, _ = self._border_distances(*self._center.nearest_point(x, y), x, y)
        return "inner" if d_inner < d_outer else "outer"

    # ----- internals -----------------------------------------------------------------------------------------

    def _prev_next(self, ndist: float) -> tuple[int, int]:
        n = len(self._waypoint_ndists)
        next_idx = bisect.bisect_right(self._waypoint_ndists, ndist)
        prev_idx = next_idx - 1
        if prev_idx == -1:
            prev_idx = n - 1
        if next_idx == n:
            next_idx = 0
        return prev_idx, next_idx

    def _nearer_of(self, x: float, y: float, prev_idx: int, next_idx: int) -> int:
        px, py = self._waypoint_tuples[prev_idx]
        nx, ny = self._waypoint_tuples[next_idx]
        return next_idx if math.hypot(x - nx, y - ny) < math.hypot(x - px, y - py) else prev_idx

    def _border_distances(self, cx: float, cy: float, x: float, y: float) -> tuple[float, float, float]:
        """Distances from (x, y) to the inner/outer border points nearest to the centre point, and their spacing."""
        ix, iy, ox, oy = self._borders.nearest_points(cx, cy)
        return math.hypot(x - ix, y - iy), math.hypot(x - ox, y - oy), math.hypot(ix - ox, iy - oy)


def read_route_file(path: str | Path) -> np.ndarray:
    """Read and validate a DeepRacer route file; consecutive duplicate rows are dropped (as the current SimApp)."""
    path = Path(path)
    if not path.is_file():
        raise TrackError(f"{path}: route file not found")
    try:
        raw = np.load(path, allow_pickle=False)
    except (ValueError, OSError, EOFError) as exc:
        raise TrackError(f"{path}: not a readable .npy array ({exc})") from exc
    if not isinstance(raw, np.ndarray) or raw.ndim != 2 or raw.shape[1] != 6:
        shape = getattr(raw, "shape", None)
        raise TrackError(f"{path}: expected an array of shape (N, 6) [center, inner, outer x,y], got shape {shape}")
    if not (np.issubdtype(raw.dtype, np.floating) or np.issubdtype(raw.dtype, np.integer)):
        raise TrackError(f"{path}: expected float64 coordinates, got dtype {raw.dtype}")
    waypoints = raw.astype(np.float64)
    if not np.all(np.isfinite(waypoints)):
        bad = int(np.argwhere(~np.isfinite(waypoints))[0, 0])
        raise TrackError(f"{path}: row {bad} contains NaN or infinite coordinates")
    keep = np.ones(len(waypoints), dtype=bool)
    keep[1:] = np.any(waypoints[1:, 0:2] != waypoints[:-1, 0:2], axis=1)
    waypoints = waypoints[keep]
    is_loop = len(waypoints) > 1 and np.array_equal(waypoints[0], waypoints[-1])
    minimum = 4 if is_loop else 2
    if len(waypoints) < minimum:
        raise TrackError(f"{path}: needs at least {minimum} distinct waypoints, got {len(waypoints)}")
    widths = np.hypot(*(waypoints[:, 2:4] - waypoints[:, 4:6]).T)
    if np.any(widths <= 0.0):
        raise TrackError(f"{path}: inner and outer border coincide at row {int(np.argmin(widths))}")
    return waypoints


def route_facts(path: Path) -> tuple[float, float, str, int]:
    """(centre-line length m, mean width m, direction, waypoint rows) straight from a route file's rows."""
    rows = read_route_file(path)
    center = rows[:, 0:2]
    length_m = float(np.hypot(*np.diff(center, axis=0).T).sum())
    width_m = float(np.hypot(*(rows[:, 2:4] - rows[:, 4:6]).T).mean())
    if not np.array_equal(rows[0], rows[-1]):
        return length_m, width_m, "counter-clockwise", len(rows)  # an open route is driven forward as ccw
    x, y = center[:, 0], center[:, 1]
    area = float(np.dot(x, np.roll(y, -1)) - np.dot(y, np.roll(x, -1)))
    return length_m, width_m, "counter-clockwise" if area > 0 else "clockwise", len(rows)


def compute_progress(current_ndist: float, start_ndist: float, prev_progress: float) -> float:
    """Progress in % with DeepRacer's finish-line wrap rules (deepracer-simapp v5.3.3
    `bundle/markov/agent_ctrl/utils.py`); capped at 100, not floored: behind the start line it is negative, as the
    SimApp's (the reward params, simtrace and metrics all see that value)."""
    progress = 100.0 * (current_ndist - start_ndist)
    if progress <= 0.0:
        progress += 100.0
    if prev_progress > progress + 50.0:
        progress += 100.0
    if progress > prev_progress + 50.0:
        progress -= 100.0
    return min(progress, 100)
