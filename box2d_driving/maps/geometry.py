"""Plane geometry the map builder needs: polylines by arc length, offsets, Bezier curves,
intersections and containment. Points are ``(..., 2)`` arrays in metres."""

from __future__ import annotations

import numpy as np

from box2d_driving.road.geometry import points_in_polygon


def cumulative_length(points: np.ndarray) -> np.ndarray:
    return np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(points, axis=0), axis=1))])


def dedupe(points: np.ndarray, tol: float = 1e-6) -> np.ndarray:
    """Drop consecutive duplicate points."""
    points = np.asarray(points, dtype=np.float64)
    keep = np.concatenate([[True], np.linalg.norm(np.diff(points, axis=0), axis=1) > tol])
    return points[keep]


def point_at(points: np.ndarray, s: float | np.ndarray) -> np.ndarray:
    """Point(s) at arc length ``s`` along the polyline (clipped to its ends)."""
    cum = cumulative_length(points)
    s = np.clip(np.asarray(s, dtype=np.float64), 0.0, cum[-1])
    return np.stack([np.interp(s, cum, points[:, 0]), np.interp(s, cum, points[:, 1])], axis=-1)


def tangent_at(points: np.ndarray, s: float) -> np.ndarray:
    """Unit tangent of the segment containing arc length ``s``."""
    cum = cumulative_length(points)
    i = int(np.clip(np.searchsorted(cum, s, side="right") - 1, 0, len(points) - 2))
    d = points[i + 1] - points[i]
    return d / np.linalg.norm(d)


def resample(points: np.ndarray, step: float, start: float = 0.0, end: float | None = None) -> np.ndarray:
    """Points every ``step`` metres (ends included) along ``[start, end]`` of the polyline."""
    cum = cumulative_length(points)
    end = cum[-1] if end is None else min(end, cum[-1])
    if end <= start:
        raise ValueError("resample: empty range")
    n = max(int(np.ceil((end - start) / step)), 1)
    return point_at(points, np.linspace(start, end, n + 1))


def vertex_normals(points: np.ndarray) -> np.ndarray:
    """Unit right-hand normals at each vertex (average of the adjacent segments')."""
    d = np.diff(points, axis=0)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    seg_n = np.stack([d[:, 1], -d[:, 0]], axis=1)
    n = np.vstack([seg_n[:1], seg_n[:-1] + seg_n[1:], seg_n[-1:]])
    return n / np.maximum(np.linalg.norm(n, axis=1, keepdims=True), 1e-12)


def offset(points: np.ndarray, u: float) -> np.ndarray:
    """The polyline shifted ``u`` metres to its right (negative: left)."""
    return points + u * vertex_normals(points)


def bezier(p0: np.ndarray, p1: np.ndarray, p2: np.ndarray, p3: np.ndarray | None = None,
           samples: int = 24) -> np.ndarray:
    """Quadratic (``p3 is None``) or cubic Bezier curve, ``samples + 1`` points, ends exact."""
    t = np.linspace(0.0, 1.0, samples + 1)[:, None]
    if p3 is None:
        return (1 - t) ** 2 * p0 + 2 * (1 - t) * t * p1 + t ** 2 * p2
    return (1 - t) ** 3 * p0 + 3 * (1 - t) ** 2 * t * p1 + 3 * (1 - t) * t ** 2 * p2 + t ** 3 * p3


def line_intersection(p: np.ndarray, d: np.ndarray, q: np.ndarray, e: np.ndarray) -> tuple[float, float] | None:
    """Parameters ``(a, b)`` with ``p + a d == q + b e``, or None if (nearly) parallel."""
    den = d[0] * e[1] - d[1] * e[0]
    if abs(den) < 1e-9 * np.linalg.norm(d) * np.linalg.norm(e):
        return None
    w = q - p
    return float((w[0] * e[1] - w[1] * e[0]) / den), float((w[0] * d[1] - w[1] * d[0]) / den)


def segments_intersect(a0: np.ndarray, a1: np.ndarray, b0: np.ndarray, b1: np.ndarray) -> np.ndarray:
    """Whether segments ``a0a1[i]`` and ``b0b1[j]`` properly intersect, ``(len(a), len(b))``."""
    def cross(o, p, q):
        return (p[..., 0] - o[..., 0]) * (q[..., 1] - o[..., 1]) - (p[..., 1] - o[..., 1]) * (q[..., 0] - o[..., 0])

    A0, A1 = a0[:, None, :], a1[:, None, :]
    B0, B1 = b0[None, :, :], b1[None, :, :]
    d1, d2 = cross(B0, B1, A0), cross(B0, B1, A1)
    d3, d4 = cross(A0, A1, B0), cross(A0, A1, B1)
    return (d1 * d2 < 0) & (d3 * d4 < 0)


def polylines_cross(a: np.ndarray, b: np.ndarray) -> bool:
    return bool(segments_intersect(a[:-1], a[1:], b[:-1], b[1:]).any())


def segment_hits_polygon(p0: np.ndarray, p1: np.ndarray, polygon: np.ndarray) -> bool:
    """Whether segment ``p0p1`` crosses the polygon's boundary or lies inside it."""
    ring = np.vstack([polygon, polygon[:1]])
    if segments_intersect(np.array([p0]), np.array([p1]), ring[:-1], ring[1:]).any():
        return True
    return bool(points_in_polygon(np.array([0.5 * (p0 + p1)]), polygon)[0])


def distance_to_polylines(points: np.ndarray, polylines: list[np.ndarray]) -> np.ndarray:
    """Smallest distance from each point to any segment of ``polylines``, ``(N,)``."""
    a = np.vstack([p[:-1] for p in polylines])
    b = np.vstack([p[1:] for p in polylines])
    d = b - a
    t = np.einsum("nkj,kj->nk", points[:, None, :] - a[None], d) / np.maximum(np.einsum("kj,kj->k", d, d), 1e-12)
    t = np.clip(t, 0.0, 1.0)
    closest = a[None] + t[..., None] * d[None]
    return np.linalg.norm(points[:, None, :] - closest, axis=2).min(axis=1)


def min_radius(points: np.ndarray) -> float:
    """Smallest circumradius of consecutive point triples (m); inf for a straight polyline."""
    if len(points) < 3:
        return float("inf")
    a, b, c = points[:-2], points[1:-1], points[2:]
    ab, bc, ca = (np.linalg.norm(b - a, axis=1), np.linalg.norm(c - b, axis=1), np.linalg.norm(a - c, axis=1))
    area2 = np.abs((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (b[:, 1] - a[:, 1]) * (c[:, 0] - a[:, 0]))
    with np.errstate(divide="ignore"):
        r = ab * bc * ca / (2.0 * area2)
    return float(np.min(r)) if np.isfinite(r).any() else float("inf")


def clip_ring_to_square(points: np.ndarray, half: float) -> list[np.ndarray]:
    """Parts of a closed ring inside the square ``|x|, |y| <= half``, as polylines."""
    ring = np.vstack([points, points[:1]])
    pieces: list[list[np.ndarray]] = []
    current: list[np.ndarray] = []
    for a, b in zip(ring[:-1], ring[1:]):
        t0, t1, d = 0.0, 1.0, b - a
        ok = True
        for p, q in ((-d[0], a[0] + half), (d[0], half - a[0]), (-d[1], a[1] + half), (d[1], half - a[1])):
            if p == 0:
                ok = ok and q >= 0
            else:
                t = q / p
                if p < 0:
                    t0 = max(t0, t)
                else:
                    t1 = min(t1, t)
        if not ok or t0 > t1:
            if len(current) > 1:
                pieces.append(current)
            current = []
            continue
        pa, pb = a + t0 * d, a + t1 * d
        if current and np.linalg.norm(current[-1] - pa) > 1e-9:
            if len(current) > 1:
                pieces.append(current)
            current = []
        if not current:
            current = [pa]
        current.append(pb)
    if len(current) > 1:
        pieces.append(current)
    return [dedupe(np.array(p)) for p in pieces if len(dedupe(np.array(p))) > 1]


def clip_polygon_to_square(poly: np.ndarray, half: float) -> np.ndarray:
    """Sutherland-Hodgman clip of a polygon to the square ``|x|, |y| <= half``."""
    out = [p for p in poly]
    for axis, sign in ((0, 1), (0, -1), (1, 1), (1, -1)):
        src, out = out, []
        if not src:
            break
        for k, cur in enumerate(src):
            prev = src[k - 1]
            cur_in, prev_in = sign * cur[axis] <= half, sign * prev[axis] <= half
            if cur_in != prev_in:
                t = (sign * half - prev[axis]) / (cur[axis] - prev[axis])
                out.append(prev + t * (cur - prev))
            if cur_in:
                out.append(cur)
    return np.array(out) if len(out) >= 3 else np.zeros((0, 2))


def convex_hull(points: np.ndarray) -> np.ndarray:
    """Convex hull (counter-clockwise), monotone chain."""
    pts = sorted(map(tuple, np.round(points, 9)))
    if len(pts) < 3:
        return np.array(pts)

    def half(seq):
        h: list = []
        for p in seq:
            while len(h) >= 2 and ((h[-1][0] - h[-2][0]) * (p[1] - h[-2][1])
                                   - (h[-1][1] - h[-2][1]) * (p[0] - h[-2][0])) <= 0:
                h.pop()
            h.append(p)
        return h

    lower, upper = half(pts), half(reversed(pts))
    return np.array(lower[:-1] + upper[:-1])


def long_axis(poly: np.ndarray) -> np.ndarray:
    """The segment along a thin polygon's long axis, through its centroid."""
    c = poly.mean(axis=0)
    _, _, vt = np.linalg.svd(poly - c)
    u = vt[0]
    proj = (poly - c) @ u
    return np.array([c + proj.min() * u, c + proj.max() * u])
