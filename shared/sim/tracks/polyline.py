"""GEOS-identical projection on a polyline, in numpy: the track's hot path.

DeepRacer computes everything with shapely/GEOS (`LinearRing.project`, `interpolate`). Projection is on the hot path
of every env step, so it is re-implemented here with cached numpy segment arrays that follow GEOS' algorithm
operation for operation (first segment of minimum distance, clamped projection factor, sequentially accumulated
segment lengths); tests compare it with shapely to 1e-12.
"""

from __future__ import annotations

import numpy as np


class Polyline:
    """Segment arrays of one line (centre or a border), for GEOS-identical `project` / `interpolate`."""

    def __init__(self, coords: np.ndarray) -> None:
        self.coords = coords
        self.ax = np.ascontiguousarray(coords[:-1, 0])
        self.ay = np.ascontiguousarray(coords[:-1, 1])
        self.dx = coords[1:, 0] - coords[:-1, 0]
        self.dy = coords[1:, 1] - coords[:-1, 1]
        self.len2 = self.dx * self.dx + self.dy * self.dy
        self.seg_len = np.sqrt(self.len2)
        # GEOS accumulates segment lengths one after another; cumsum does the same (np.sum would not).
        self.start_measure = np.concatenate(([0.0], np.cumsum(self.seg_len)[:-1]))
        self.length = float(np.cumsum(self.seg_len)[-1])
        # Python-float copies for the scalar arithmetic after the vectorised search.
        self.start_measure_list = self.start_measure.tolist()
        self.seg_len_list = self.seg_len.tolist()
        self.ax_list, self.ay_list = self.ax.tolist(), self.ay.tolist()
        self.dx_list, self.dy_list = self.dx.tolist(), self.dy.tolist()
        self.len2_list = self.len2.tolist()

    def locate(self, x: float, y: float) -> tuple[int, float]:
        """(segment index, clamped projection factor) of the nearest point, as GEOS LengthIndexOfPoint.

        GEOS takes the first segment of minimum distance; comparing squared distances of the clamped foot points
        selects the same segment (up to sub-ulp ties, where both candidates give the same measure).
        """
        d2, r = self.squared_distances(x, y)
        i = int(np.argmin(d2))
        return i, float(r[i])

    def squared_distances(self, x: float, y: float) -> tuple[np.ndarray, np.ndarray]:
        """(squared distance from the point to each segment's nearest point, that point's clamped factor)."""
        px = x - self.ax
        py = y - self.ay
        r = (px * self.dx + py * self.dy) / self.len2
        np.clip(r, 0.0, 1.0, out=r)
        qx = px - r * self.dx
        qy = py - r * self.dy
        return qx * qx + qy * qy, r

    def project_many(self, xs: np.ndarray, ys: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """`project` and `nearest_point` of several points in one pass: (distances along the line, nearest xs,
        nearest ys). Element for element the same floating-point operations as `locate`, so the same values."""
        px = xs[:, None] - self.ax
        py = ys[:, None] - self.ay
        r = (px * self.dx + py * self.dy) / self.len2
        np.clip(r, 0.0, 1.0, out=r)
        qx = px - r * self.dx
        qy = py - r * self.dy
        i = np.argmin(qx * qx + qy * qy, axis=1)
        factor = r[np.arange(len(i)), i]
        measure = np.where(factor <= 0.0, self.start_measure[i], self.start_measure[i] + factor * self.seg_len[i])
        return measure, self.ax[i] + factor * self.dx[i], self.ay[i] + factor * self.dy[i]

    def project(self, x: float, y: float) -> float:
        """Distance along the line of the nearest point (shapely `project`)."""
        i, factor = self.locate(x, y)
        if factor <= 0.0:
            return float(self.start_measure[i])
        return float(self.start_measure[i] + factor * self.seg_len[i])

    def nearest_point(self, x: float, y: float) -> tuple[float, float]:
        """The point of the line nearest to (x, y) (shapely `interpolate(project(p))`)."""
        i, factor = self.locate(x, y)
        return float(self.ax[i] + factor * self.dx[i]), float(self.ay[i] + factor * self.dy[i])

    def interpolate(self, distance_m: float) -> tuple[float, float]:
        """The point at a distance along the line, clamped to its ends (shapely `interpolate`)."""
        distance_m = min(max(distance_m, 0.0), self.length)
        i = max(int(np.searchsorted(self.start_measure, distance_m, side="right")) - 1, 0)
        factor = (distance_m - self.start_measure[i]) / self.seg_len[i]
        factor = min(max(factor, 0.0), 1.0)
        return float(self.ax[i] + factor * self.dx[i]), float(self.ay[i] + factor * self.dy[i])


class BorderPair:
    """Inner and outer border stacked, so both nearest points come from one vectorised pass (same maths)."""

    def __init__(self, inner: Polyline, outer: Polyline) -> None:
        self.ax = np.stack([inner.ax, outer.ax])
        self.ay = np.stack([inner.ay, outer.ay])
        self.dx = np.stack([inner.dx, outer.dx])
        self.dy = np.stack([inner.dy, outer.dy])
        self.len2 = np.stack([inner.len2, outer.len2])
        self._lists = (self.ax.tolist(), self.ay.tolist(), self.dx.tolist(), self.dy.tolist())

    def nearest_points(self, x: float, y: float) -> tuple[float, float, float, float]:
        """(inner x, inner y, outer x, outer y) nearest to (x, y)."""
        px = x - self.ax
        py = y - self.ay
        r = (px * self.dx + py * self.dy) / self.len2
        np.clip(r, 0.0, 1.0, out=r)
        qx = px - r * self.dx
        qy = py - r * self.dy
        i_in, i_out = (qx * qx + qy * qy).argmin(axis=1).tolist()
        f_in = float(r[0, i_in])
        f_out = float(r[1, i_out])
        ax, ay, dx, dy = self._lists
        return (
            ax[0][i_in] + f_in * dx[0][i_in],
            ay[0][i_in] + f_in * dy[0][i_in],
            ax[1][i_out] + f_out * dx[1][i_out],
            ay[1][i_out] + f_out * dy[1][i_out],
        )
