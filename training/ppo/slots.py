"""The slot layout: one observation row per car slot, ``[own obs (D) | team obs (N x D) | alive (N) |
own alive (1)]``, and the checks on slot actions (used by :mod:`training.ppo.vec_env`, read by the
rollout buffer and the policy)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from gymnasium import spaces


@dataclass(frozen=True)
class TeamLayout:
    """Slices of a slot observation: ``own`` (D), ``team`` (N x D), ``alive`` (N), ``self_alive``."""

    obs_dim: int
    n_cars: int

    @property
    def own(self) -> slice:
        return slice(0, self.obs_dim)

    @property
    def team(self) -> slice:
        return slice(self.obs_dim, self.obs_dim * (1 + self.n_cars))

    @property
    def alive(self) -> slice:
        start = self.obs_dim * (1 + self.n_cars)
        return slice(start, start + self.n_cars)

    @property
    def self_alive(self) -> int:
        return self.obs_dim * (1 + self.n_cars) + self.n_cars

    @property
    def size(self) -> int:
        return self.self_alive + 1


def slot_observation_space(base_space: spaces.Box, n_cars: int) -> spaces.Box:
    """The space of a slot observation (``TeamLayout``) for cars whose own space is ``base_space``."""
    low = np.concatenate([np.tile(base_space.low, 1 + n_cars), np.zeros(n_cars + 1)])
    high = np.concatenate([np.tile(base_space.high, 1 + n_cars), np.ones(n_cars + 1)])
    return spaces.Box(low.astype(np.float32), high.astype(np.float32), dtype=np.float32)


def slot_rows(own: np.ndarray, alive: np.ndarray, lay: TeamLayout) -> np.ndarray:
    """Slot observations ``(K, N, size)`` of ``K`` instances from each car's own observation
    ``(K, N, D)`` (zero for absent cars) and alive flag ``(K, N)``: every slot carries its
    instance's whole team."""
    k_all, n, d = own.shape
    out = np.empty((k_all, n, lay.size), dtype=np.float32)
    out[:, :, lay.own] = own
    out[:, :, lay.team] = own.reshape(k_all, 1, n * d)
    out[:, :, lay.alive] = alive[:, None, :]
    out[:, :, lay.self_alive] = alive
    return out


def clear_slot(rows: np.ndarray, i: int, lay: TeamLayout) -> None:
    """Turn car ``i`` of one instance's slot observations ``rows`` ``(N, size)`` into padding in
    place: what :func:`slot_rows` writes when that car's own observation and alive flag are zero."""
    rows[:, lay.team.start + i * lay.obs_dim: lay.team.start + (i + 1) * lay.obs_dim] = 0.0
    rows[:, lay.alive.start + i] = 0.0
    rows[i, lay.own] = 0.0
    rows[i, lay.self_alive] = 0.0


def checked_actions(actions: np.ndarray, n_actions: int) -> np.ndarray:
    """Slot actions as int64, or :class:`ActionError` naming the first one outside ``[0, n)``."""
    from box2d_driving.envs.actions import ActionError

    raw = actions.astype(np.int64)
    if actions.dtype.kind not in "iu" and not np.array_equal(raw, actions):
        raise ActionError(f"slot actions must be integers, got {actions.tolist()}")
    if raw.size and (raw.min() < 0 or raw.max() >= n_actions):
        bad = raw[(raw < 0) | (raw >= n_actions)][0]
        raise ActionError(f"slot actions must be in [0, {n_actions}), got {bad}")
    return raw
