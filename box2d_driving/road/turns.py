"""Tracks that turn at a four-way junction: straight in, a quarter circle, straight out.

A car approaches along unit direction ``d`` at ``lane`` metres to one side of its road's axis
(``side``, a unit vector perpendicular to ``d``) and leaves along ``n``, perpendicular to ``d``.
The junction is the ``2 half x 2 half`` box about the origin. The turn is the quarter circle about
the junction corner ``-half d + half n`` through the car's entry point on the junction's edge:
radius ``half - lane`` when the car turns towards its own side, ``half + lane`` across the road.
It leaves the junction at the same distance ``lane`` from the exit road's axis, on the side a car
driving on the same side of the road keeps to. Coordinates in metres.
"""

from __future__ import annotations

import math

import numpy as np

from box2d_driving.road.geometry import Path

# chords per quarter circle: the polyline's arc falls short of the circle's by
# 1 - sin(x)/x at x = pi / (4 * 24), under 0.03 % (3 mm on a 12 m turn)
TURN_SEGMENTS = 24


def exit_direction(direction: np.ndarray, turn: int) -> np.ndarray:
    """The direction a car driving along ``direction`` leaves in: ``turn`` 0 straight on, 1 to
    its left (counter-clockwise), -1 to its right."""
    d = np.asarray(direction, dtype=np.float64)
    if turn == 0:
        return d.copy()
    if turn not in (1, -1):
        raise ValueError(f"turn must be 0, 1 or -1, got {turn!r}")
    return turn * np.array([-d[1], d[0]])


def turning_track(direction: np.ndarray, side: np.ndarray, lane: float, half: float, before: float,
                  out: np.ndarray, after: float) -> tuple[Path, float]:
    """The track of a car that starts ``before`` metres ahead of (before) the junction's edge,
    ``lane`` metres towards ``side`` of its axis, drives along ``direction``, turns into ``out``
    (perpendicular to ``direction``) and ends ``after`` metres past the exit edge. Returns the
    path and the arc length (m) at which it leaves the junction."""
    d = np.asarray(direction, dtype=np.float64)
    n = np.asarray(out, dtype=np.float64)
    entry = -half * d + lane * np.asarray(side, dtype=np.float64)
    centre = -half * d + half * n
    radius = float(np.linalg.norm(entry - centre))
    t = np.linspace(0.0, 0.5 * math.pi, TURN_SEGMENTS + 1)
    arc = centre + radius * (-np.cos(t)[:, None] * n + np.sin(t)[:, None] * d)
    leave = arc[-1]
    points = np.concatenate([[entry - before * d], arc, [leave + after * n]])
    path = Path.from_points(points)
    return path, float(path.cumlen[-2]) if after > 0 else path.length


# vertices per radian of the paper's code's turn (its circle part spans 1 rad, the rest 0.57)
PAPER_TURN_VERTICES_PER_RAD = 24


def paper_turning_track(direction: np.ndarray, side: np.ndarray, lane: float, half: float, before: float,
                        out: np.ndarray, end_along: float) -> Path:
    """The track of :func:`turning_track` as the paper's code moves a turning car
    (``_FixedTrackAccelerationModel`` in its ``tsim/dynamics.py``), in the limit of short steps:
    after the ``before`` metres to the junction's edge the car's heading turns by ``arc / (pi r /
    2)`` radians after ``arc`` metres driven (``r`` the quarter circle's radius), capped at a
    right angle. While ``arc < pi r / 2`` its position is read off the quarter circle at that
    heading, so it covers the circle's first radian only, at 2 / pi of its speed; then it moves
    at its speed along that still-turning heading (a circle of radius ``pi r / 2`` through the
    remaining 0.57 rad) and on straight along ``out`` until ``end_along`` metres from the
    junction's centre along ``out``. The returned path's ``cumlen`` is the distance the car
    drives (its speed's integral), longer than the polyline on the circle part."""
    d = np.asarray(direction, dtype=np.float64)
    n = np.asarray(out, dtype=np.float64)
    sign = float(d[0] * n[1] - d[1] * n[0])  # +1: a left (counter-clockwise) turn
    entry = -half * d + lane * np.asarray(side, dtype=np.float64)
    centre = -half * d + half * n
    radius = float(np.linalg.norm(entry - centre))
    quarter = 0.5 * math.pi * radius  # the arc length the heading's turn is measured in
    theta1 = math.atan2(d[1], d[0])

    def on_circle(phi: np.ndarray) -> np.ndarray:
        theta = theta1 + sign * phi
        return centre + sign * radius * np.stack([np.sin(theta), -np.cos(theta)], axis=-1)

    phi_circle = np.linspace(0.0, 1.0, PAPER_TURN_VERTICES_PER_RAD + 1)
    circle = on_circle(phi_circle)
    rest = 0.5 * math.pi - 1.0
    phi_rest = np.linspace(1.0, 0.5 * math.pi, int(math.ceil(rest * PAPER_TURN_VERTICES_PER_RAD)) + 1)[1:]
    theta_rest = theta1 + sign * phi_rest
    theta_one = theta1 + sign * 1.0
    spiral = circle[-1] + sign * quarter * np.stack(
        [np.sin(theta_rest) - math.sin(theta_one), -(np.cos(theta_rest) - math.cos(theta_one))], axis=-1)
    last = spiral[-1]
    tail = end_along - float(last @ n)
    points = np.concatenate([[entry - before * d], circle, spiral, [last + tail * n]])
    cumlen = np.concatenate([[0.0], before + quarter * phi_circle, before + quarter * phi_rest,
                             [before + quarter * 0.5 * math.pi + tail]])
    if before <= 0.0 or tail <= 0.0:
        raise ValueError(f"a turning track needs room before ({before:.2f} m) and after ({tail:.2f} m) its turn")
    return Path(points, cumlen)
