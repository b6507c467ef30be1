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

TERMS = ("goal", "collision", "smoothness", "progress")


def reward_terms(*, arrived: np.ndarray, collided: np.ndarray, accel_level: np.ndarray,
                 prev_accel_level: np.ndarray, accel_range: float, remaining: np.ndarray,
                 initial: np.ndarray, decision: int, horizon: int, goal_reward: float,
                 collision_reward: float) -> dict[str, np.ndarray]:
    """Reward terms for the cars given (arrays of equal length). ``decision`` is 1-based; the
    acceleration levels are the unscaled action values (m/s^2)."""
    frac = remaining / initial
    remaining_decisions = np.where(collided, horizon - decision + 1, 1)
    return {
        "goal": np.where(arrived, goal_reward, 0.0),
        "collision": np.where(collided, collision_reward, 0.0),
        "smoothness": -np.abs(accel_level - prev_accel_level) / accel_range / horizon,
        "progress": -frac * remaining_decisions / horizon,
    }
