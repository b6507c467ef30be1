"""The reward, as named terms.

Per car and decision, with ``H`` the horizon, ``d0`` the path length at spawn and ``d`` what
remains:

* ``goal``: ``goal_reward`` on the decision the car reaches its goal;
* ``collision``: ``collision_reward`` on the decision of its first collision;
* ``smoothness``: ``-(1/H) * |a_t - a_{t-1}| / (a_hi - a_lo)``. The paper divides by ``a_max``;
  with a symmetric range a full swing is ``2 a_max``, so dividing by the range keeps the episode
  sum within [-1, 1];
* ``progress``: ``-(1/H) * d / d0``; on the collision decision the car also pays the progress
  penalty it would have paid until the horizon, ``(H - t) * (1/H) * d / d0`` more, so crashing is
  never cheaper than driving on.

Each term's undiscounted episode sum lies within [-1, 1].
"""

from __future__ import annotations

import numpy as np
from numba import njit

TERMS = ("goal", "collision", "smoothness", "progress")


def reward_terms(*, arrived: np.ndarray, collided: np.ndarray, accel_level: np.ndarray,
                 prev_accel_level: np.ndarray, accel_range: float, remaining: np.ndarray,
                 initial: np.ndarray, decision: int | np.ndarray, horizon: int, goal_reward: float,
                 collision_reward: float) -> dict[str, np.ndarray]:
    """Reward terms for the cars given (arrays of equal length). ``decision`` is 1-based, one for
    all cars or one per car; the acceleration levels are the unscaled action values (m/s^2)."""
    n = len(arrived)
    out = np.empty((len(TERMS), n))
    decision = np.asarray(decision, dtype=np.int64)
    if decision.ndim == 0:
        decision = np.full(n, decision)
    _reward_terms(np.asarray(arrived, dtype=np.bool_), np.asarray(collided, dtype=np.bool_),
                  np.asarray(accel_level, dtype=np.float64), np.asarray(prev_accel_level, dtype=np.float64),
                  float(accel_range), np.asarray(remaining, dtype=np.float64), np.asarray(initial, dtype=np.float64),
                  decision, int(horizon), float(goal_reward),
                  float(collision_reward), out)
    return dict(zip(TERMS, out))


# compiled: every car, every decision; the formulas in the order of the module's docstring, each
# worked out with the same operations as the numpy expressions they replaced (same values)
@njit(cache=True)
def _reward_terms(arrived, collided, level, prev, accel_range, remaining, initial, decision, horizon,
                  goal_reward, collision_reward, out):
    for k in range(arrived.shape[0]):
        out[0, k] = goal_reward if arrived[k] else 0.0
        out[1, k] = collision_reward if collided[k] else 0.0
        out[2, k] = -abs(level[k] - prev[k]) / accel_range / horizon
        # a crash pays the progress penalty of every decision left, this one included
        left = horizon - decision[k] + 1 if collided[k] else 1
        out[3, k] = -(remaining[k] / initial[k]) * left / horizon
