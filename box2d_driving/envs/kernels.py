"""The env core's per-car formulas, compiled (``numba``).

Each runs for every car every decision; over the handful of cars of a decision a dozen small
numpy calls cost more than the arithmetic. Every kernel does the same operations in the same
order as the whole-array numpy version it replaced, so the numbers are the same to the bit
(``tests/test_env_golden.py`` fingerprints 1,000 decisions of every env). Arrays are gathered
over the instances stepped together (``num_cars`` rows each); ``rows`` picks the cars that
acted, and output row ``k`` belongs to car ``rows[k]``.
"""

from __future__ import annotations

from numba import njit


@njit(cache=True)
def axis_offsets_and_stop_distances(rows, positions, lane_origin, lane_right, lane_half_width, stop_point,
                                    stop_direction, offset, stop):
    """For car ``rows[k]`` of the gathered arrays: ``offset[k]``, its signed distance right of its
    lane axis in half widths, and ``stop[k]``, how far its stop line lies ahead (m, negative once
    past it); NaN where it has no axis or no light (those inputs are NaN). Plain products and one
    sum per car, so the same rounding as the vector product of one car's two 2-vectors (whose sum
    starts from +0.0: an axis offset of zero is +0.0, never -0.0)."""
    for k in range(rows.shape[0]):
        i = rows[k]
        x = positions[i, 0]
        y = positions[i, 1]
        offset[k] = (0.0 + (x - lane_origin[i, 0]) * lane_right[i, 0]
                     + (y - lane_origin[i, 1]) * lane_right[i, 1]) / lane_half_width[i]
        stop[k] = ((stop_point[i, 0] - x) * stop_direction[i, 0]
                   + (stop_point[i, 1] - y) * stop_direction[i, 1])


@njit(cache=True)
def satnav_columns(rows, positions, s_end, s, goals, speed, v_lim, seen, satnav, to_goal, remaining):
    """The sat-nav values that need no angle: ``satnav[k, 0]`` the light seen, ``[k, 1]``
    ``speed / v_lim``, ``[k, 3]`` ``1 / max(distance to goal, 1)`` (float32, rounded once from
    float64); and for the heading error worked out by the caller, ``to_goal[:, k]``, the vector
    from the car to its goal (m), and ``remaining[k]``, its path still to drive (m)."""
    for k in range(rows.shape[0]):
        i = rows[k]
        rem = s_end[i] - s[i]
        remaining[k] = rem
        to_goal[0, k] = goals[i, 0] - positions[i, 0]
        to_goal[1, k] = goals[i, 1] - positions[i, 1]
        satnav[k, 0] = seen[i]
        satnav[k, 1] = speed[i] / v_lim[i]
        satnav[k, 3] = 1.0 / max(rem, 1.0)


@njit(cache=True)
def split_actions(rows, raw, levels, ratings, communication, level, bits, accel):
    """Car ``rows[k]``'s raw action ``raw[k]`` (``bit * len(levels) + level index`` with
    messages, else the level index) into ``level[i]`` (m/s^2, the action's value), ``bits[i]``
    (the message bit, with ``communication``) and ``accel[i]``, the level scaled by the car's
    acceleration rating (m/s^2). Cars not in ``rows`` keep what the arrays hold."""
    n_levels = levels.shape[0]
    for k in range(rows.shape[0]):
        i = rows[k]
        level[i] = levels[raw[k] % n_levels]
        if communication:
            bits[i] = raw[k] // n_levels
        accel[i] = level[i] * ratings[i]
