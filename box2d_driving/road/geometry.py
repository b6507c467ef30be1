"""Paths that cars follow: polylines with arc length, and centripetal Catmull-Rom splines.

All coordinates are metres in the world frame; headings are radians counter-clockwise from +x.
"""

from __future__ import annotations

import math
from typing import overload
from dataclasses import dataclass

import numpy as np
from numba import njit


@dataclass(frozen=True)
class Path:
    """A polyline parameterised by arc length.

    Attributes:
        points: ``(P, 2)`` vertices (m), P >= 2, consecutive vertices distinct.
        cumlen: ``(P,)`` arc length at each vertex (m); ``cumlen[0] == 0``. A track that a car
            drives off its geometry (the paper's code's turns,
            :func:`box2d_driving.road.turns.paper_turning_track`) gives the distance driven
            instead, increasing but not the polyline's length.
    """

    points: np.ndarray
    cumlen: np.ndarray

    @staticmethod
    def from_points(points: np.ndarray) -> "Path":
        """The polyline through ``points`` ``(P, 2)`` (m), repeated vertices dropped; ValueError
        unless at least two distinct 2-D points remain."""
        pts = np.asarray(points, dtype=np.float64)
        if pts.ndim != 2 or pts.shape[1] != 2 or len(pts) < 2:
            raise ValueError(f"a path needs at least two 2-D points, got shape {pts.shape}")
        seg = np.linalg.norm(np.diff(pts, axis=0), axis=1)
        keep = np.concatenate([[True], seg > 1e-9])
        pts = pts[keep]
        if len(pts) < 2:
            raise ValueError("a path needs two distinct points")
        cumlen = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(pts, axis=0), axis=1))])
        return Path(pts, cumlen)

    @staticmethod
    def straight(start: np.ndarray, end: np.ndarray) -> "Path":
        """The segment from ``start`` to ``end``: ``from_points`` of the two points, the same
        numbers (its norm is ``sqrt(dx * dx + dy * dy)`` too), built without its general checks
        (a reset builds one per car)."""
        pts = np.array([start, end], dtype=np.float64)
        if pts.shape != (2, 2):
            raise ValueError(f"a path needs at least two 2-D points, got shape {pts.shape}")
        dx, dy = pts[1] - pts[0]
        length = np.sqrt(dx * dx + dy * dy)
        if not length > 1e-9:
            raise ValueError("a path needs two distinct points")
        return Path(pts, np.array([0.0, length]))

    def start_pose(self) -> tuple[np.ndarray, np.ndarray]:
        """``pose(0.0)``, the same numbers, without the search along the path."""
        a = self.points[0]
        d = self.points[1] - a
        return a + 0.0 * d, np.arctan2(d[..., 1], d[..., 0])

    @property
    def length(self) -> float:
        """Total arc length (m)."""
        return float(self.cumlen[-1])

    def pose(self, s: np.ndarray | float) -> tuple[np.ndarray, np.ndarray]:
        """Position ``(..., 2)`` and heading ``(...)`` at arc length ``s`` (clipped to the path)."""
        s = np.clip(np.asarray(s, dtype=np.float64), 0.0, self.length)
        idx = np.clip(np.searchsorted(self.cumlen, s, side="right") - 1, 0, len(self.points) - 2)
        a = self.points[idx]
        b = self.points[idx + 1]
        seg = self.cumlen[idx + 1] - self.cumlen[idx]
        u = ((s - self.cumlen[idx]) / seg)[..., None]
        d = b - a
        return a + u * d, np.arctan2(d[..., 1], d[..., 0])

    def project(self, point: np.ndarray) -> float:
        """Arc length of the closest point of the path to ``point``."""
        p = np.asarray(point, dtype=np.float64)
        a, b = self.points[:-1], self.points[1:]
        d = b - a
        u = np.clip(np.einsum("ij,ij->i", p - a, d) / np.einsum("ij,ij->i", d, d), 0.0, 1.0)
        dist = np.linalg.norm(a + u[:, None] * d - p, axis=1)
        i = int(np.argmin(dist))
        return float(self.cumlen[i] + u[i] * (self.cumlen[i + 1] - self.cumlen[i]))


def catmull_rom(control: np.ndarray, alpha: float = 0.5, samples_per_segment: int = 64) -> np.ndarray:
    """Sample a Catmull-Rom spline through ``control`` points ``(K, 2)`` (m).

    ``alpha = 0.5`` is the centripetal parameterisation (no cusps or self-intersections within a
    segment). The curve passes through every control point; the end segments use mirrored
    phantom points so that it starts at the first and ends at the last control point.

    Returns ``(1 + (K - 1) * samples_per_segment, 2)`` points, the control points included exactly.
    """
    p = np.asarray(control, dtype=np.float64)
    if p.ndim != 2 or p.shape[1] != 2 or len(p) < 2:
        raise ValueError(f"catmull_rom needs at least two 2-D control points, got {p.shape}")
    return catmull_rom_many(p[None], alpha, samples_per_segment)[0]


def catmull_rom_many(control: np.ndarray, alpha: float = 0.5, samples_per_segment: int = 64) -> np.ndarray:
    """:func:`catmull_rom` of ``N`` splines at once: control points ``(N, K, 2)`` (m) to samples
    ``(N, 1 + (K - 1) * samples_per_segment, 2)``.

    Every sample is the same sequence of floating-point operations as one spline's segment by
    segment (the knot spacings are scalar ``norm ** alpha`` per control-point gap, the blends are
    elementwise), so a spline's samples do not depend on which others it is computed with; one
    pass of array operations over all splines and segments instead of a few dozen small ones per
    segment (a spline env's reset builds a path per car).
    """
    p = np.asarray(control, dtype=np.float64)
    if p.ndim != 3 or p.shape[2] != 2 or p.shape[1] < 2:
        raise ValueError(f"catmull_rom_many needs (N, K >= 2, 2) control points, got {p.shape}")
    n, k = p.shape[:2]
    if n == 0:
        return np.empty((0, 1 + (k - 1) * samples_per_segment, 2))
    ext = np.concatenate([2 * p[:, :1] - p[:, 1:2], p, 2 * p[:, -1:] - p[:, -2:-1]], axis=1)
    gaps = ext[:, 1:] - ext[:, :-1]  # (N, K + 1, 2)
    # knot increments |gap| ** alpha as scalars, as np.linalg.norm of one 2-vector computes the
    # length (sqrt of its dot product) and Python's pow raises it: the array versions may round
    # differently (numpy takes sqrt for ** 0.5 and may fuse the dot's products)
    inc = np.array([[max(math.sqrt(g.dot(g)), 1e-9) ** alpha for g in row] for row in gaps])
    # knots t0 = 0 < t1 < t2 < t3 of segment i, each (N, K - 1, 1, 1)
    t1 = 0.0 + inc[:, :-2]
    t2 = t1 + inc[:, 1:-1]
    t3 = t2 + inc[:, 2:]
    t1, t2, t3 = (t[:, :, None, None] for t in (t1, t2, t3))
    p0, p1, p2, p3 = (ext[:, j:j + k - 1, None, :] for j in range(4))  # (N, K - 1, 1, 2)
    u = np.linspace(0.0, 1.0, samples_per_segment + 1)[1:, None]
    t = t1 + u * (t2 - t1)  # (N, K - 1, S, 1)
    a1 = (t1 - t) / t1 * p0 + t / t1 * p1
    a2 = (t2 - t) / (t2 - t1) * p1 + (t - t1) / (t2 - t1) * p2
    a3 = (t3 - t) / (t3 - t2) * p2 + (t - t2) / (t3 - t2) * p3
    b1 = (t2 - t) / t2 * a1 + t / t2 * a2
    b2 = (t3 - t) / (t3 - t1) * a2 + (t - t1) / (t3 - t1) * a3
    c = (t2 - t) / (t2 - t1) * b1 + (t - t1) / (t2 - t1) * b2
    c[:, :, -1] = p2[:, :, 0]  # exact at the control point
    return np.concatenate([p[:, :1], c.reshape(n, -1, 2)], axis=1)


def spline_path(control: np.ndarray, alpha: float = 0.5, samples_per_segment: int = 64) -> Path:
    """A :class:`Path` along the centripetal Catmull-Rom spline through ``control``."""
    return Path.from_points(catmull_rom(control, alpha, samples_per_segment))


def spline_paths(control: np.ndarray, alpha: float = 0.5, samples_per_segment: int = 64) -> list[Path]:
    """:func:`spline_path` of each of ``N`` control-point sets ``(N, K, 2)``, the same paths
    (sampled together by :func:`catmull_rom_many`)."""
    return [Path.from_points(pts) for pts in catmull_rom_many(control, alpha, samples_per_segment)]


def pack_paths(paths: list[Path]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Pad paths into arrays for batched kernels: points ``(N, P, 2)``, cumlen ``(N, P)``,
    vertex counts ``(N,)``. Padding repeats the last vertex."""
    n = len(paths)
    p_max = max(len(p.points) for p in paths) if paths else 2
    pts = np.zeros((n, p_max, 2))
    cum = np.zeros((n, p_max))
    counts = np.zeros(n, dtype=np.int64)
    for i, path in enumerate(paths):
        k = len(path.points)
        pts[i, :k] = path.points
        pts[i, k:] = path.points[-1]
        cum[i, :k] = path.cumlen
        cum[i, k:] = path.cumlen[-1]
        counts[i] = k
    return pts, cum, counts


def rectangle_corners(x: float, y: float, heading: float, length: float, width: float) -> np.ndarray:
    """Corners ``(4, 2)`` of a rectangle centred at (x, y), counter-clockwise."""
    c, s = np.cos(heading), np.sin(heading)
    hl, hw = length / 2, width / 2
    local = np.array([[hl, -hw], [hl, hw], [-hl, hw], [-hl, -hw]])
    rot = np.array([[c, -s], [s, c]])
    return local @ rot.T + np.array([x, y])


def rectangles_overlap(a: np.ndarray, b: np.ndarray) -> bool:
    """Separating-axis test for two convex polygons given as ``(K, 2)`` corner arrays."""
    for poly in (a, b):
        edges = np.roll(poly, -1, axis=0) - poly
        for ex, ey in edges:
            axis = np.array([-ey, ex])
            pa = a @ axis
            pb = b @ axis
            if pa.max() <= pb.min() or pb.max() <= pa.min():
                return False
    return True


@overload
def wrap_angle(angle: float) -> float: ...
@overload
def wrap_angle(angle: np.ndarray) -> np.ndarray: ...
def wrap_angle(angle):
    """Wrap to ``[-pi, pi)`` (a number stays a number, an array an array)."""
    return (np.asarray(angle) + np.pi) % (2 * np.pi) - np.pi


def points_in_polygon(points: np.ndarray, polygon: np.ndarray) -> np.ndarray:
    """Even-odd rule containment of each point ``(N, 2)`` in ``polygon`` ``(K, 2)``, ``(N,)`` bool."""
    out = np.empty(len(points), dtype=bool)
    _points_in_polygon(np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 2),
                       np.ascontiguousarray(polygon, dtype=np.float64).reshape(-1, 2), out)
    return out


def points_in_box(points: np.ndarray, box: tuple[float, float, float, float]) -> np.ndarray:
    """Whether each point ``(N, 2)`` lies in the axis-aligned ``box`` ``(x0, y0, x1, y1)``, edges
    included, ``(N,)`` bool."""
    out = np.empty(len(points), dtype=bool)
    x0, y0, x1, y1 = box
    _points_in_box(np.ascontiguousarray(points, dtype=np.float64).reshape(-1, 2),
                   float(x0), float(y0), float(x1), float(y1), out)
    return out


@njit(cache=True)
def _points_in_box(points, x0, y0, x1, y1, out):
    """:func:`points_in_box` compiled (every car, every decision at the paper's junctions)."""
    for i in range(points.shape[0]):
        x = points[i, 0]
        y = points[i, 1]
        out[i] = x0 <= x <= x1 and y0 <= y <= y1


@njit(cache=True)
def _points_in_polygon(points, polygon, out):
    """:func:`points_in_polygon` compiled (the env asks it for every car every decision on the
    real junctions, whose outlines have dozens of corners): edge ``j`` runs from corner ``j`` to
    ``j + 1`` (the last back to the first), and a point counts the edges that cross its
    horizontal line to its right, the crossing's ``x`` worked out as
    ``xa + (y - ya) * (xb - xa) / (yb - ya)``."""
    k = polygon.shape[0]
    for i in range(points.shape[0]):
        x = points[i, 0]
        y = points[i, 1]
        inside = False
        for j in range(k):
            xa = polygon[j, 0]
            ya = polygon[j, 1]
            xb = polygon[(j + 1) % k, 0]
            yb = polygon[(j + 1) % k, 1]
            if (ya > y) != (yb > y) and x < xa + (y - ya) * (xb - xa) / (yb - ya):
                inside = not inside
        out[i] = inside
