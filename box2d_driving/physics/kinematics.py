"""Batched longitudinal kinematics along paths (Numba kernels).

A car's acceleration is held for a whole decision; speed is clipped to ``[0, v_lim]``. Within each
physics step the motion is integrated exactly (piecewise constant acceleration, clipping included),
so a car's arc length at the end of every step matches the analytic answer; or, with ``euler``, as
the paper's code does: the car moves at its speed of the step's start, then its speed changes.
Box2D is then given the chord velocity that carries the body from one step's pose to the next.
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def advance_speed(v: float, a: float, v_lim: float, dt: float) -> tuple[float, float]:
    """Exact distance travelled and end speed after ``dt`` at acceleration ``a``, speed in
    ``[0, v_lim]``."""
    v1 = v + a * dt
    if v1 > v_lim:
        tau = (v_lim - v) / a if a > 0.0 else 0.0
        return 0.5 * (v + v_lim) * tau + v_lim * (dt - tau), v_lim
    if v1 < 0.0:
        tau = -v / a if a < 0.0 else 0.0
        return 0.5 * v * tau, 0.0
    return 0.5 * (v + v1) * dt, v1


@njit(cache=True)
def euler_speed(v: float, a: float, v_min: float, v_max: float, dt: float) -> tuple[float, float]:
    """The paper's code's step: distance ``v * dt`` at the step's starting speed, then the speed
    ``v + a * dt`` clipped to ``[v_min, v_max]``."""
    return v * dt, min(max(v + a * dt, v_min), v_max)


@njit(cache=True)
def longitudinal_profile(s0, v0, accel, v_lim, s_end, moving, dt, substeps, s_out, v_out, arrive, euler=False):
    """Arc length ``s_out[i, k]`` and speed ``v_out[i, k]`` at the end of each physics step
    ``k = 0..substeps`` (column 0 is the start) for every moving car; ``arrive[i]`` is the first
    step index (1-based) at which the car reaches ``s_end[i]``, or 0. ``euler``: each step by
    :func:`euler_speed` instead of exactly."""
    n = s0.shape[0]
    for i in range(n):
        s = s0[i]
        v = v0[i]
        s_out[i, 0] = s
        v_out[i, 0] = v
        arrive[i] = 0
        for k in range(substeps):
            if moving[i] and arrive[i] == 0:
                if euler:
                    ds, v = euler_speed(v, accel[i], 0.0, v_lim[i], dt)
                else:
                    ds, v = advance_speed(v, accel[i], v_lim[i], dt)
                s = s + ds
                if s >= s_end[i]:
                    s = s_end[i]
                    arrive[i] = k + 1
            s_out[i, k + 1] = s
            v_out[i, k + 1] = v


@njit(cache=True)
def path_poses(points, cumlen, counts, s, xy_out, heading_out):
    """Position and heading at arc lengths ``s[i, k]`` on each car's padded polyline."""
    n, m = s.shape
    for i in range(n):
        c = counts[i]
        for k in range(m):
            si = s[i, k]
            lo = 0
            hi = c - 2
            # last segment whose start arc length is <= si
            while lo < hi:
                mid = (lo + hi + 1) // 2
                if cumlen[i, mid] <= si:
                    lo = mid
                else:
                    hi = mid - 1
            ax = points[i, lo, 0]
            ay = points[i, lo, 1]
            dx = points[i, lo + 1, 0] - ax
            dy = points[i, lo + 1, 1] - ay
            seg = cumlen[i, lo + 1] - cumlen[i, lo]
            u = (si - cumlen[i, lo]) / seg if seg > 0.0 else 0.0
            if u < 0.0:
                u = 0.0
            elif u > 1.0:
                u = 1.0
            xy_out[i, k, 0] = ax + u * dx
            xy_out[i, k, 1] = ay + u * dy
            heading_out[i, k] = np.arctan2(dy, dx)


@njit(cache=True)
def chord_velocities(xy, rows, dt, velocity, always, never):
    """For car ``rows[j]``: ``velocity[j, k]``, the chord velocity from its pose at step ``k`` to
    step ``k + 1`` (``(xy[k + 1] - xy[k]) / dt``, m/s); ``always[j]``, whether it is non-zero at
    every step, and ``never[j]``, at none (a car waiting at a red light)."""
    for j in range(rows.shape[0]):
        i = rows[j]
        moves = 0
        for k in range(velocity.shape[1]):
            vx = (xy[i, k + 1, 0] - xy[i, k, 0]) / dt
            vy = (xy[i, k + 1, 1] - xy[i, k, 1]) / dt
            velocity[j, k, 0] = vx
            velocity[j, k, 1] = vy
            if vx != 0.0 or vy != 0.0:
                moves += 1
        always[j] = moves == velocity.shape[1]
        never[j] = moves == 0


@njit(cache=True)
def advance_speed_between(v: float, a: float, v_min: float, v_max: float, dt: float) -> tuple[float, float]:
    """Exact distance travelled and end speed after ``dt`` at acceleration ``a``, speed in
    ``[v_min, v_max]`` (``v_min < 0``: the car can reverse)."""
    v1 = v + a * dt
    if v1 > v_max:
        tau = (v_max - v) / a if a > 0.0 else 0.0
        return 0.5 * (v + v_max) * tau + v_max * (dt - tau), v_max
    if v1 < v_min:
        tau = (v_min - v) / a if a < 0.0 else 0.0
        return 0.5 * (v + v_min) * tau + v_min * (dt - tau), v_min
    return 0.5 * (v + v1) * dt, v1


@njit(cache=True)
def free_profile(s0, v0, accel, v_min, v_max, s_goal, s_end, arrived, moving, dt, substeps, s_out, v_out, arrive,
                 euler=False):
    """:func:`longitudinal_profile` for cars that may reverse and that drive on past their goal:
    speed in ``[v_min[i], v_max[i]]``, arc length kept in ``[0, s_end[i]]`` (the path's ends; the
    speed is 0 while pressed against one), ``arrive[i]`` the first step (1-based) at which a car
    not ``arrived`` before reaches ``s_goal[i]``, or 0. Motion goes on after arrival. ``euler``:
    each step by :func:`euler_speed` instead of exactly."""
    n = s0.shape[0]
    for i in range(n):
        s = s0[i]
        v = v0[i]
        s_out[i, 0] = s
        v_out[i, 0] = v
        arrive[i] = 0
        for k in range(substeps):
            if moving[i]:
                if euler:
                    ds, v = euler_speed(v, accel[i], v_min[i], v_max[i], dt)
                else:
                    ds, v = advance_speed_between(v, accel[i], v_min[i], v_max[i], dt)
                s = s + ds
                if s > s_end[i]:
                    s = s_end[i]
                    v = 0.0
                elif s < 0.0:
                    s = 0.0
                    v = 0.0
                if not arrived[i] and arrive[i] == 0 and s >= s_goal[i]:
                    arrive[i] = k + 1
            s_out[i, k + 1] = s
            v_out[i, k + 1] = v
