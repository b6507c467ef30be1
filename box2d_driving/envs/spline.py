"""Spline scenarios: each car first chooses its own path (stage 0), then drives along it with
acceleration control (stage 1) exactly as on the fixed tracks (training: ``docs/lanes.md``).

Lanes are never given. ``reset`` plans the episode (map, spawns and each car's route along the
road axis), asks for one stage-0 action per car and builds each car's centripetal Catmull-Rom path
from the chosen control points. The stage-0 action comes, in this order, from
``reset(options={"spline_actions": ...})``, from ``env.spline_policy`` (a callable mapping the
``(N, D0)`` stage-0 observations to ``N`` actions; the bilevel trainer installs the spline
sub-policy here) or from the scenario's default (the route along the road axis).

For the one-step bandit (``training/ppo/bandit.py``) the reset can be split in two:
``obs0 = env.plan(seed)`` draws the episode and returns the stage-0 observations, then
``env.reset(options={"use_plan": True, "spline_actions": actions})`` finishes it. ``plan`` is the
first half of ``reset``: it is where the seed goes, and nothing else draws from ``np_random``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, Callable, Optional

import numpy as np
from gymnasium import spaces

from box2d_driving.envs.actions import ActionError
from box2d_driving.road.layout import Layout

if TYPE_CHECKING:  # the type checker sees the env it is mixed into
    from box2d_driving.envs.base import DrivingEnv as _Host
else:
    _Host = object

SplinePolicy = Callable[[np.ndarray], np.ndarray]


class SplineStageMixin(_Host):
    """Adds the stage-0 path choice to a :class:`~box2d_driving.envs.base.DrivingEnv`.

    Scenarios implement :meth:`spline_observation_values` and :meth:`apply_spline` (action 0 must
    mean the route along the road axis) and set ``spline_observation_space`` / ``spline_action_space``
    in ``__init__`` (one object each, returned on every call).
    """

    spline_policy: Optional[SplinePolicy] = None
    spline_observation_space: spaces.Box
    spline_action_space: spaces.Discrete | spaces.MultiDiscrete | spaces.Box

    # -- scenario hooks -----------------------------------------------------------------------
    def spline_observation_values(self, layout: Layout) -> np.ndarray:
        """``(N, D0)`` stage-0 observations of the planned layout."""
        raise NotImplementedError

    def apply_spline(self, layout: Layout, actions: np.ndarray) -> Layout:
        """The planned layout with every car's path replaced by the one its action picks."""
        raise NotImplementedError

    def default_spline_actions(self) -> np.ndarray:
        """Stage-0 actions used when nobody chooses: all zeros, which every spline scenario
        defines as the route along the road axis."""
        space = self.spline_action_space
        return np.zeros((len(self.possible_agents),) + _shape(space), dtype=space.dtype)

    # -- two-phase reset ----------------------------------------------------------------------
    def plan(self, seed: Optional[int] = None) -> dict[str, np.ndarray]:
        """First half of ``reset``: draw the episode and return each car's stage-0 observation."""
        self._planned: Optional[Layout] = self.build_layout(self._seed(seed))
        self._planned_obs = self.spline_observation_values(self._planned).astype(np.float32)
        return {a: self._planned_obs[i] for i, a in enumerate(self.possible_agents)}

    def _new_layout(self, seed: Optional[int], options: dict) -> Layout:
        if options.get("use_plan"):
            if getattr(self, "_planned", None) is None:
                raise RuntimeError("reset(options={'use_plan': True}) needs a plan(): call env.plan(seed) first")
            if seed is not None:
                raise ValueError("the seed of a planned episode goes to plan(seed), not reset()")
        else:
            self.plan(seed)
        layout, obs0 = self._planned, self._planned_obs
        self._planned = None
        assert layout is not None  # planned just above
        actions = self._stage0_actions(options.get("spline_actions"), obs0)
        self.spline_observations = obs0
        self.spline_actions = actions
        return self.apply_spline(layout, actions)

    def _stage0_actions(self, given: Any, obs0: np.ndarray) -> np.ndarray:
        n = len(self.possible_agents)
        if given is None and self.spline_policy is not None:
            given = self.spline_policy(obs0)
        if given is None:
            return self.default_spline_actions()
        if isinstance(given, dict):
            missing = [a for a in self.possible_agents if a not in given]
            if missing:
                raise ActionError(f"spline_actions: no stage-0 action for {missing}")
            given = [given[a] for a in self.possible_agents]
        space = self.spline_action_space
        try:
            actions = np.asarray(given)
        except (ValueError, TypeError) as exc:
            raise ActionError(f"spline actions must be an array of numbers, got {given!r} ({exc})") from None
        if isinstance(space, (spaces.Discrete, spaces.MultiDiscrete)) and actions.dtype.kind not in "iu":
            raise ActionError(f"spline actions must be integers, got {actions.dtype} values {actions.tolist()}")
        if actions.dtype.kind not in "iuf":
            raise ActionError(f"spline actions must be numbers, got {actions.dtype} values {actions.tolist()}")
        per_car = int(np.prod(_shape(space)))
        if actions.size != n * per_car:
            raise ActionError(f"spline actions must hold {per_car} value(s) for each of the {n} cars, "
                              f"got shape {actions.shape}")
        actions = actions.astype(space.dtype)
        if isinstance(space, spaces.Discrete):
            actions = actions.reshape(n)
            if actions.min() < 0 or actions.max() >= space.n:
                raise ActionError(f"spline actions must be in [0, {space.n}), got {actions.tolist()}")
        elif isinstance(space, spaces.MultiDiscrete):
            actions = actions.reshape((n,) + _shape(space))
            if actions.min() < 0 or np.any(actions >= space.nvec):
                raise ActionError(f"spline actions must be in [0, {space.nvec.tolist()}), got {actions.tolist()}")
        else:
            actions = actions.reshape((n,) + _shape(space))
            if not np.all(np.isfinite(actions)):
                raise ActionError("spline actions must be finite")
            actions = np.clip(actions, space.low, space.high)  # as SB3 clips Box actions
        return actions


def _shape(space: spaces.Space) -> tuple[int, ...]:
    """A space's shape (``()`` for a Discrete one)."""
    return tuple(space.shape or ())
