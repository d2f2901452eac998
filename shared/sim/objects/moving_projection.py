"""Centre-line projections of points that move a little between calls (bot cars), exact and mostly without a search
of the whole line.

A full search (`Track.project_points_m`, all segments) also notes, for each point, the nearest distance from it to
any segment outside a window around its nearest segment. After the point has moved by d, every segment outside the
window is still at least that distance minus d away (triangle inequality); while the window's best segment is
nearer than that, with a margin far above rounding, the nearest segment of the whole line is in the window, and the
window, searched in index order with the same arithmetic, gives the very segment, factor and values of a full search.
Otherwise the point gets a new full search and a new window. A bot at 0.5 m/s moves 3 cm per step, so most steps
search a dozen segments instead of every one.
"""

from __future__ import annotations

import math

import numpy as np

from racer.shared.sim.tracks.track import Track

WINDOW_SEGMENTS = 6
"""Segments searched on either side of the last full search's nearest one."""
SAFETY_MARGIN_M = 1e-9
"""Far above the rounding of the distances compared (ulps of metres), far below anything geometric."""


class MovingProjection:
    """`project_points_m` for a fixed number of moving points (index = point), the same values as a full search."""

    def __init__(self, track: Track, count: int) -> None:
        self._line = track.center_segments
        n = len(self._line.seg_len_list)
        self._closed = track.is_loop
        self._segments = n
        self._window: list[list[int]] = [[] for _ in range(count)]
        self._anchor: list[tuple[float, float]] = [(math.nan, math.nan)] * count
        self._outside_m = [-math.inf] * count
        """Per point: the nearest distance from its anchor to a segment outside its window."""
        self.full_searches = 0

    def project(self, xs: list[float], ys: list[float]) -> tuple[list[float], list[float], list[float]]:
        """(metres along the centre line, nearest xs, nearest ys) of each point."""
        measures, near_xs, near_ys = [], [], []
        for k, (x, y) in enumerate(zip(xs, ys, strict=True)):
            found = self._in_window(k, x, y)
            if found is None:
                found = self._full_search(k, x, y)
            i, factor = found
            line = self._line
            start = line.start_measure_list[i]
            measures.append(start if factor <= 0.0 else start + factor * line.seg_len_list[i])
            near_xs.append(line.ax_list[i] + factor * line.dx_list[i])
            near_ys.append(line.ay_list[i] + factor * line.dy_list[i])
        return measures, near_xs, near_ys

    def _in_window(self, k: int, x: float, y: float) -> tuple[int, float] | None:
        """The nearest segment and factor when the window provably holds it, else None."""
        window = self._window[k]
        if not window:
            return None
        moved_m = math.hypot(x - self._anchor[k][0], y - self._anchor[k][1])
        bound_m = self._outside_m[k] - moved_m - SAFETY_MARGIN_M
        if bound_m <= 0.0:
            return None
        line = self._line
        ax, ay, dx, dy, len2 = line.ax_list, line.ay_list, line.dx_list, line.dy_list, line.len2_list
        best_i, best_r, best_d2 = -1, 0.0, math.inf
        for i in window:  # ascending: ties go to the first segment, as in the full search
            px = x - ax[i]
            py = y - ay[i]
            r = min(max((px * dx[i] + py * dy[i]) / len2[i], 0.0), 1.0)
            qx = px - r * dx[i]
            qy = py - r * dy[i]
            d2 = qx * qx + qy * qy
            if d2 < best_d2:
                best_i, best_r, best_d2 = i, r, d2
        if math.sqrt(best_d2) >= bound_m:
            return None
        return best_i, best_r

    def _full_search(self, k: int, x: float, y: float) -> tuple[int, float]:
        self.full_searches += 1
        line = self._line
        d2, r = line.squared_distances(x, y)
        i = int(np.argmin(d2))
        n = self._segments
        if self._closed:
            window = sorted({(i + j) % n for j in range(-WINDOW_SEGMENTS, WINDOW_SEGMENTS + 1)})
        else:
            window = list(range(max(i - WINDOW_SEGMENTS, 0), min(i + WINDOW_SEGMENTS + 1, n)))
        outside = np.delete(d2, window)
        self._window[k] = window if outside.size else []
        self._outside_m[k] = math.sqrt(float(outside.min())) if outside.size else -math.inf
        self._anchor[k] = (x, y)
        return i, float(r[i])
