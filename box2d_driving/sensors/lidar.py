"""LiDAR: ``n_rays`` rays over 360 degrees from each car's centre, starting at its heading.

Two backends return the same distances (they agree within 1e-3 m; tests check every ray):

* ``numba``: all cars x all rays at once. Each segment of the scene is tested only against the
  rays whose directions fall inside the angle it subtends, so the cost grows with what is in view,
  not with ``n_rays x segments``; a car's ray directions are kept while its heading stays the same
  (:class:`RayDirections`).
* ``box2d``: one ``world.RayCast`` per ray with a closest-hit callback.

Semantics shared by both: the car's own body is excluded; a ray hits the first car, halted car,
pedestrian or road edge within ``range``; a polygon is seen only from outside (as Box2D does);
``inf`` means no return.
"""

from __future__ import annotations

import math

import numpy as np
from box2d_driving.physics.box2d_py import b2RayCastCallback
from numba import njit

from box2d_driving.physics.contacts import PEDESTRIAN


OWNER_EDGE = -1
OWNER_PEDESTRIAN = -2


@njit(cache=True)
def _fill_box_segments(centres, headings, half_length, half_width, out, row):
    """Write the 4 counter-clockwise sides of each rectangle into ``out`` from ``row`` on."""
    for i in range(centres.shape[0]):
        c = math.cos(headings[i])
        s = math.sin(headings[i])
        hl = half_length[i]
        hw = half_width[i]
        xs = (hl, hl, -hl, -hl)
        ys = (-hw, hw, hw, -hw)
        for j in range(4):
            k = (j + 1) % 4
            r = row + 4 * i + j
            out[r, 0] = centres[i, 0] + xs[j] * c - ys[j] * s
            out[r, 1] = centres[i, 1] + xs[j] * s + ys[j] * c
            out[r, 2] = centres[i, 0] + xs[k] * c - ys[k] * s
            out[r, 3] = centres[i, 1] + xs[k] * s + ys[k] * c


def scene_segments(car_positions: np.ndarray, car_headings: np.ndarray, car_present: np.ndarray,
                   car_length: float, car_width: float, ped_positions: np.ndarray,
                   ped_size: np.ndarray, edges: np.ndarray):
    """Everything a ray can hit as segments.

    Returns ``segs (M, 4)`` as ``[ax, ay, bx, by]``, ``owner (M,)`` (car index, or
    ``OWNER_EDGE`` / ``OWNER_PEDESTRIAN``) and ``one_sided (M,)`` (polygon sides, counter-clockwise,
    hit only from outside): the present cars' boxes, then the pedestrians', then the edges.
    """
    edges = np.asarray(edges, dtype=np.float64).reshape(-1, 4)
    ped_positions = np.asarray(ped_positions, dtype=np.float64).reshape(-1, 2)
    ped_size = np.asarray(ped_size, dtype=np.float64).reshape(-1)
    return _scene_segments(np.asarray(car_positions, dtype=np.float64), np.asarray(car_headings, dtype=np.float64),
                           np.asarray(car_present, dtype=np.bool_), car_length / 2, car_width / 2,
                           ped_positions, ped_size / 2, edges)


@njit(cache=True)
def _scene_segments(car_positions, car_headings, car_present, half_length, half_width, ped_positions,
                    ped_half, edges):
    """:func:`scene_segments` in one compiled call (it runs once per decision per env)."""
    cars = np.flatnonzero(car_present)
    n_car, n_ped = cars.shape[0], ped_positions.shape[0]
    boxes = 4 * (n_car + n_ped)
    segs = np.empty((boxes + edges.shape[0], 4))
    _fill_box_segments(car_positions[cars], car_headings[cars], np.full(n_car, half_length),
                       np.full(n_car, half_width), segs, 0)
    if n_ped:
        _fill_box_segments(ped_positions, np.zeros(n_ped), ped_half, ped_half, segs, 4 * n_car)
    segs[boxes:] = edges
    owner = np.empty(segs.shape[0], dtype=np.int64)
    for i in range(n_car):
        owner[4 * i:4 * i + 4] = cars[i]
    owner[4 * n_car:boxes] = OWNER_PEDESTRIAN
    owner[boxes:] = OWNER_EDGE
    one_sided = np.zeros(segs.shape[0], dtype=np.bool_)
    one_sided[:boxes] = True
    return segs, owner, one_sided


class RayDirections:
    """The direction of every ray of ``slots`` observers (``cos`` and ``sin`` of ``heading + k *
    2 pi / n_rays``, ``(slots, n_rays)`` each), kept between calls: a slot whose heading has not
    changed since its last call reuses them. A pure memo (the same ``math.cos`` / ``math.sin`` of
    the same heading), so results never depend on which car last used a slot; a car driving
    straight keeps its heading to the bit, and these two functions were about half the kernel's
    time at the intersection."""

    def __init__(self, slots: int, n_rays: int) -> None:
        self.heading = np.full(slots, np.nan)  # NaN: never equal, so a new slot computes its rays
        self.cos = np.empty((slots, n_rays))
        self.sin = np.empty((slots, n_rays))

    @classmethod
    def sized(cls, memo: "RayDirections | None", slots: int, n_rays: int) -> "RayDirections":
        """``memo`` if it has this shape, else a new one."""
        if memo is not None and memo.cos.shape == (slots, n_rays):
            return memo
        return cls(slots, n_rays)


@njit(cache=True)
def cast_rays(origins, headings, observer, n_rays, max_range, segs, owner, one_sided, out, min_range=0.0):
    """Closest hit distance of every ray of every observer; ``inf`` where nothing is in range.

    ``observer[c]`` is the car index of observer ``c`` (its own segments are skipped). Hits nearer
    than ``min_range`` are not seen: the ray goes on to the next one (the paper's LiDAR).
    """
    n = origins.shape[0]
    _cast_rays_in(origins, headings, observer, np.arange(n), np.zeros(n, np.int64), np.full(n, segs.shape[0], np.int64),
                  n_rays, max_range, segs, owner, one_sided, np.full(n, np.nan), np.empty((n, n_rays)),
                  np.empty((n, n_rays)), out, min_range)


# Half-width (rad) added on each side of a segment's angular span when choosing the rays to test:
# far above the error of ``_approx_atan2`` (2e-5 rad), far below a ray's spacing (2 pi / n_rays). A
# ray outside the widened span misses the segment by at least this angle, which moves its crossing
# point off the segment by much more than rounding, so testing it could never record a hit.
_SPAN_MARGIN = 1e-4


@njit(cache=True)
def _approx_atan2(y, x):
    """``atan2(y, x)`` within 2e-5 rad (the polynomial of Abramowitz & Stegun 4.4.49 on [0, 1],
    extended by octant), about a third of the library call's time. Only chooses which rays a
    segment is tested against (with :data:`_SPAN_MARGIN`); distances come from the exact test."""
    ax = abs(x)
    ay = abs(y)
    if ax == 0.0 and ay == 0.0:
        return 0.0
    z = ay / ax if ax >= ay else ax / ay
    z2 = z * z
    a = z * (0.9998660 + z2 * (-0.3302995 + z2 * (0.1801410 + z2 * (-0.0851330 + z2 * 0.0208351))))
    if ay > ax:
        a = 0.5 * math.pi - a
    if x < 0.0:
        a = math.pi - a
    if y < 0.0:
        a = -a
    return a


@njit(cache=True)
def _cast_rays_in(origins, headings, observer, slot, seg_lo, seg_hi, n_rays, max_range, segs, owner, one_sided,
                  memo_heading, memo_cos, memo_sin, out, min_range):
    """:func:`cast_rays` with observer ``c`` seeing only the segments ``seg_lo[c]:seg_hi[c]`` (its
    own scene when several scenes' segments are stacked), its ray directions kept in row
    ``slot[c]`` of the memo arrays (see :class:`RayDirections`)."""
    dtheta = 2.0 * math.pi / n_rays
    r2max = max_range * max_range
    for c in range(origins.shape[0]):
        ox = origins[c, 0]
        oy = origins[c, 1]
        h = headings[c]
        cos_r = memo_cos[slot[c]]
        sin_r = memo_sin[slot[c]]
        if memo_heading[slot[c]] != h:
            for k in range(n_rays):
                cos_r[k] = math.cos(h + k * dtheta)
                sin_r[k] = math.sin(h + k * dtheta)
            memo_heading[slot[c]] = h
        for k in range(n_rays):
            out[c, k] = math.inf
        for m in range(seg_lo[c], seg_hi[c]):
            if owner[m] == observer[c]:
                continue
            ax = segs[m, 0] - ox
            ay = segs[m, 1] - oy
            bx = segs[m, 2] - ox
            by = segs[m, 3] - oy
            ex = bx - ax
            ey = by - ay
            # a one-sided (box) segment facing away from the origin: every ray that could reach it
            # has ``denom`` of this sign, so below it is skipped as one-sided or as ``t < 0``
            if one_sided[m] and ax * ey - ay * ex > 0.0:
                continue
            ll = ex * ex + ey * ey
            if ll <= 0.0:
                continue
            u = -(ax * ex + ay * ey) / ll
            if u < 0.0:
                u = 0.0
            elif u > 1.0:
                u = 1.0
            px = ax + u * ex
            py = ay + u * ey
            d2 = px * px + py * py
            if d2 > r2max:
                continue
            alpha = _approx_atan2(ay, ax) - h
            beta = _approx_atan2(by, bx) - h
            span = beta - alpha
            span = (span + math.pi) % (2.0 * math.pi) - math.pi
            if abs(abs(span) - math.pi) < 10.0 * _SPAN_MARGIN or d2 < 1e-12:
                # the origin on or next to the segment: which half it spans is not certain, test all
                k0 = 0
                k1 = n_rays - 1
            else:
                # the rays whose angles lie in the span (widened by the margin): the others miss
                start = alpha if span >= 0.0 else beta
                k0 = int(math.ceil((start - _SPAN_MARGIN) / dtheta))
                k1 = int(math.floor((start + abs(span) + _SPAN_MARGIN) / dtheta))
                if k1 - k0 >= n_rays:
                    k0 = 0
                    k1 = n_rays - 1
            for kk in range(k0, k1 + 1):
                k = kk % n_rays
                out[c, k] = _ray_hit(ax, ay, ex, ey, cos_r[k], sin_r[k], one_sided[m], max_range, out[c, k],
                                     min_range)


@njit(cache=True)
def _ray_hit(ax, ay, ex, ey, rc, rs, one_sided, max_range, closest, min_range):
    """The distance along the ray from the origin in direction ``(rc, rs)`` to the segment from
    ``(ax, ay)`` to ``(ax + ex, ay + ey)`` (relative to the origin) where it crosses it closer
    than ``closest`` and within ``max_range``; else ``closest``. A ``one_sided`` segment (a box
    side, counter-clockwise) is hit only from outside; a crossing nearer than ``min_range`` is
    not a hit."""
    denom = rc * ey - rs * ex
    if denom == 0.0 or (one_sided and denom > 0.0):
        return closest
    t = (ax * ey - ay * ex) / denom
    if t < min_range or t > max_range or t >= closest:
        return closest
    s = (ax * rs - ay * rc) / denom
    return t if 0.0 <= s <= 1.0 else closest


def cast_rays_scenes(car_positions: np.ndarray, car_headings: np.ndarray, car_present: np.ndarray,
                     n_cars: int, observers: np.ndarray, car_length: float, car_width: float,
                     ped_positions: np.ndarray, ped_sizes: np.ndarray, ped_counts: np.ndarray,
                     edges: np.ndarray, edge_counts: np.ndarray, n_rays: int, max_range: float,
                     directions: RayDirections | None = None, min_range: float = 0.0) -> np.ndarray:
    """Distances ``(len(observers), n_rays)`` of ``K`` scenes at once, each as
    :func:`scene_segments` and :func:`cast_rays` would give them alone.

    Scene ``k`` holds cars ``k * n_cars .. (k + 1) * n_cars - 1`` of ``car_positions`` (``(K *
    n_cars, 2)``), ``car_headings`` and ``car_present``, the next ``ped_counts[k]`` rows of
    ``ped_positions`` / ``ped_sizes`` and the next ``edge_counts[k]`` segments of ``edges``
    (``(E, 4)``); ``observers`` are indices into the cars, and each sees only its own scene.
    ``directions``: a :class:`RayDirections` of ``K * n_cars`` slots kept by the caller between
    calls (car ``j`` uses slot ``j``); without one the directions are worked out afresh.
    """
    out = np.empty((len(observers), n_rays))
    if directions is None:
        directions = RayDirections(len(car_present), n_rays)
    elif directions.cos.shape != (len(car_present), n_rays):
        raise ValueError(f"directions has {directions.cos.shape} slots x rays, the scenes need "
                         f"{(len(car_present), n_rays)}")
    _cast_rays_scenes(car_positions, car_headings, car_present, n_cars, observers, car_length / 2, car_width / 2,
                      ped_positions, ped_sizes / 2, ped_counts, edges, edge_counts, n_rays, float(max_range),
                      directions.heading, directions.cos, directions.sin, out, float(min_range))
    return out


@njit(cache=True)
def _cast_rays_scenes(car_positions, car_headings, car_present, n_cars, observers, half_length, half_width,
                      ped_positions, ped_half, ped_counts, edges, edge_counts, n_rays, max_range,
                      memo_heading, memo_cos, memo_sin, out, min_range):
    """:func:`cast_rays_scenes` in one compiled call (it runs every decision)."""
    segs, owner, one_sided, seg_start = _scenes_segments(
        car_positions, car_headings, car_present, n_cars, half_length, half_width,
        ped_positions, ped_half, ped_counts, edges, edge_counts)
    scene = observers // n_cars
    _cast_rays_in(car_positions[observers], car_headings[observers], observers % n_cars, observers,
                  seg_start[scene], seg_start[scene + 1], n_rays, max_range, segs, owner, one_sided,
                  memo_heading, memo_cos, memo_sin, out, min_range)


@njit(cache=True)
def _scenes_segments(car_positions, car_headings, car_present, n_cars, half_length, half_width,
                     ped_positions, ped_half, ped_counts, edges, edge_counts):
    """:func:`scene_segments` of several scenes stacked (see :func:`cast_rays_scenes`), and the
    first segment of each scene (``K + 1`` entries)."""
    n_scenes = ped_counts.shape[0]
    seg_start = np.zeros(n_scenes + 1, dtype=np.int64)
    for k in range(n_scenes):
        present = 0
        for i in range(n_cars):
            if car_present[k * n_cars + i]:
                present += 1
        seg_start[k + 1] = seg_start[k] + 4 * (present + ped_counts[k]) + edge_counts[k]
    segs = np.empty((seg_start[n_scenes], 4))
    owner = np.empty(seg_start[n_scenes], dtype=np.int64)
    one_sided = np.zeros(seg_start[n_scenes], dtype=np.bool_)
    p0, e0 = 0, 0
    for k in range(n_scenes):
        base = k * n_cars
        cars = np.flatnonzero(car_present[base:base + n_cars])
        n_car, n_ped = cars.shape[0], ped_counts[k]
        row = seg_start[k]
        _fill_box_segments(car_positions[base + cars], car_headings[base + cars], np.full(n_car, half_length),
                           np.full(n_car, half_width), segs, row)
        if n_ped:
            _fill_box_segments(ped_positions[p0:p0 + n_ped], np.zeros(n_ped), ped_half[p0:p0 + n_ped],
                               ped_half[p0:p0 + n_ped], segs, row + 4 * n_car)
        boxes = 4 * (n_car + n_ped)
        segs[row + boxes:seg_start[k + 1]] = edges[e0:e0 + edge_counts[k]]
        for i in range(n_car):
            owner[row + 4 * i:row + 4 * i + 4] = cars[i]
        owner[row + 4 * n_car:row + boxes] = OWNER_PEDESTRIAN
        owner[row + boxes:seg_start[k + 1]] = OWNER_EDGE
        one_sided[row:row + boxes] = True
        p0 += n_ped
        e0 += edge_counts[k]
    return segs, owner, one_sided, seg_start


class _ClosestHit(b2RayCastCallback):
    """Closest fixture along a ray, ignoring one body."""

    def __init__(self, see_pedestrians: bool = True, min_fraction: float = 0.0) -> None:
        super().__init__()
        self.see_pedestrians = see_pedestrians
        self.min_fraction = min_fraction  # hits nearer than this share of the ray are passed through
        self.ignore = None
        self.fraction = 1.0
        self.hit = False

    def ReportFixture(self, fixture, point, normal, fraction):
        if fixture.body is self.ignore:
            return -1.0
        if not self.see_pedestrians and fixture.userData[0] == PEDESTRIAN:
            return -1.0
        if fraction < self.min_fraction:
            return 1.0  # not seen: the ray goes on unclipped
        self.hit = True
        self.fraction = fraction
        return fraction


def cast_rays_box2d(world, bodies, origins, headings, n_rays: int, max_range: float,
                    see_pedestrians: bool = True, min_range: float = 0.0) -> np.ndarray:
    """The same distances as :func:`cast_rays`, through ``world.RayCast``. ``bodies[c]`` is
    observer ``c``'s own body (excluded)."""
    out = np.full((len(origins), n_rays), np.inf)
    cb = _ClosestHit(see_pedestrians, min_range / max_range)
    angles = np.arange(n_rays) * (2.0 * math.pi / n_rays)
    for c in range(len(origins)):
        ox, oy = float(origins[c, 0]), float(origins[c, 1])
        cb.ignore = bodies[c]
        for k in range(n_rays):
            th = headings[c] + angles[k]
            end = (ox + max_range * math.cos(th), oy + max_range * math.sin(th))
            cb.hit, cb.fraction = False, 1.0
            world.RayCast(cb, (ox, oy), end)
            if cb.hit:
                out[c, k] = cb.fraction * max_range
    return out
