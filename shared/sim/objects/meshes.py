"""A bot car's look as two triangle meshes (its body, its four wheels): two draws per car instead of seven.

With software GL every geom costs the env's own thread a draw call and the vertex work of its triangles, even when
the car is out of sight. MuJoCo's cylinder is drawn in 4 stacks with subdivided caps (about 260 triangles per
wheel); a wheel here is the same 12-sided prism in 48 triangles, and the body's three boxes are one mesh of their
36 triangles. Faces keep flat normals on the boxes and the caps and radial normals round the tyre, as MuJoCo's own
shapes have, so the picture stays that of the geoms it replaces (tested: within one grey level).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

WHEEL_SIDES = 12
"""The number of slices the scene gave MuJoCo's cylinders before (`numslices`): the same outline."""


class MeshBuilder:
    """Vertices with their normals and outward triangles, built part by part."""

    def __init__(self) -> None:
        self._vertices: list[tuple[float, float, float]] = []
        self._normals: list[tuple[float, float, float]] = []
        self._faces: list[tuple[int, int, int]] = []

    def _vertex(self, point: np.ndarray, normal: np.ndarray) -> int:
        self._vertices.append(tuple(float(v) for v in point))
        self._normals.append(tuple(float(v) for v in normal))
        return len(self._vertices) - 1

    def _triangle(self, a: int, b: int, c: int, outward: np.ndarray) -> None:
        """Wound counter-clockwise seen from `outward` (GL's front face)."""
        p = np.array([self._vertices[a], self._vertices[b], self._vertices[c]])
        if np.dot(np.cross(p[1] - p[0], p[2] - p[0]), outward) < 0:
            b, c = c, b
        self._faces.append((a, b, c))

    def box(self, center: Sequence[float], half: Sequence[float]) -> None:
        """An axis-aligned box: each face its own four vertices with the face's normal (flat shading)."""
        center, half = np.asarray(center, dtype=float), np.asarray(half, dtype=float)
        for axis in range(3):
            u, v = (axis + 1) % 3, (axis + 2) % 3
            for sign in (1.0, -1.0):
                normal = np.zeros(3)
                normal[axis] = sign
                corners = []
                for su, sv in ((-1, -1), (1, -1), (1, 1), (-1, 1)):
                    offset = np.zeros(3)
                    offset[axis], offset[u], offset[v] = sign * half[axis], su * half[u], sv * half[v]
                    corners.append(self._vertex(center + offset, normal))
                self._triangle(corners[0], corners[1], corners[2], normal)
                self._triangle(corners[0], corners[2], corners[3], normal)

    def wheel(self, center: Sequence[float], radius_m: float, half_width_m: float, sides: int = WHEEL_SIDES) -> None:
        """A cylinder along y: smooth tyre (radial normals), flat caps."""
        center = np.asarray(center, dtype=float)
        angles = [2.0 * math.pi * k / sides for k in range(sides)]
        radial = [np.array([math.cos(a), 0.0, math.sin(a)]) for a in angles]
        across = np.array([0.0, 1.0, 0.0])
        for k in range(sides):
            n0, n1 = radial[k], radial[(k + 1) % sides]
            quad = [
                self._vertex(center + radius_m * n0 - half_width_m * across, n0),
                self._vertex(center + radius_m * n1 - half_width_m * across, n1),
                self._vertex(center + radius_m * n1 + half_width_m * across, n1),
                self._vertex(center + radius_m * n0 + half_width_m * across, n0),
            ]
            outward = n0 + n1
            self._triangle(quad[0], quad[1], quad[2], outward)
            self._triangle(quad[0], quad[2], quad[3], outward)
        for side in (1.0, -1.0):
            normal = side * across
            hub = self._vertex(center + half_width_m * normal, normal)
            rim = [self._vertex(center + half_width_m * normal + radius_m * n, normal) for n in radial]
            for k in range(sides):
                self._triangle(hub, rim[k], rim[(k + 1) % sides], normal)

    def mjcf(self, name: str) -> str:
        """A `<mesh>` asset element with explicit vertices, normals and faces."""
        vertex = " ".join(f"{c:.6g}" for point in self._vertices for c in point)
        normal = " ".join(f"{c:.6g}" for n in self._normals for c in n)
        face = " ".join(str(i) for f in self._faces for i in f)
        return f'    <mesh name="{name}" vertex="{vertex}" normal="{normal}" face="{face}"/>'

    @property
    def triangles(self) -> int:
        return len(self._faces)
