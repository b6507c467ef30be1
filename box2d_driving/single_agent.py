"""Single-agent Gymnasium versions of the scenarios: the learner drives one car among others.

    import gymnasium as gym
    import box2d_driving  # registers the ids below

    env = gym.make("box2d_driving/Intersection-v0")         # or Highway-v0, Crosswalk-v0, RealJunction-v0
    obs, info = env.reset(seed=0)
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())

The learner drives ``car_0`` (its observation, action, reward, termination and truncation are
exactly the multi-agent env's for that car); every other car is driven by a **background policy**:

* the scenario's shipped policy (``assets/policies/...``) when this is a source checkout, run with
  numpy alone (no training extra needed), with the env settings it was trained on (LiDAR noise,
  sat-nav fields; the number of cars and the reward stay yours to set);
* otherwise a scripted one: the light rule (brake on yellow and red) at junctions, the
  privileged pedestrian oracle at the crosswalk, full throttle on the highway.

Rendered, the lights are drawn as a trained background reads them (the value its cars stop on is
red). ``background="rule"`` (or any scripted name, or a run folder) chooses it explicitly, and
``env.unwrapped.background_name`` says which one drives. The episode ends when the learner's car
does (arrives, collides, or reaches the horizon). The spline scenarios stay multi-agent: their
first stage (each car choosing its path) is a second, one-step decision per episode.
"""

from __future__ import annotations

import warnings
from pathlib import Path
from typing import Any, Optional

import gymnasium as gym
import numpy as np

from box2d_driving.policies.shipped import SHIPPED_POLICIES_DIR
from box2d_driving.registry import make as make_parallel

EGO = "car_0"
SHIPPED = SHIPPED_POLICIES_DIR  # assets/policies in a checkout, the package's copy in a wheel


def single_agent_ids() -> dict[str, tuple[str, Optional[str], str]]:
    """Gymnasium id -> (multi-agent env id, shipped background policy, scripted fall-back), from
    the scenario records that have a single-agent version (:mod:`box2d_driving.scenarios`)."""
    from box2d_driving.scenarios import scenarios

    return {s.single_agent.gym_id: (env_id, s.single_agent.background, s.single_agent.fallback)
            for env_id, s in scenarios().items() if s.single_agent is not None}


# settings of a shipped policy that are the learner's business, not the observation's
_YOURS = ("num_cars", "collision_reward", "goal_reward", "horizon", "remove_collided")


class SingleAgentDrivingEnv(gym.Env):
    """One car of a multi-agent driving env, the others driven by a background policy.

    Args:
        env_id: the multi-agent env id (``intersection-v0``, ...).
        background: ``None`` (the shipped policy if it can be loaded, else ``fallback``), a
            scripted policy name (``rule``, ``random``, ``full-throttle``, ``pedestrian-oracle``)
            or a path to a trained policy (a run folder or its ``model.safetensors``).
        fallback: the scripted policy used when no shipped policy can be loaded.
        shipped: the shipped policy's folder name under ``assets/policies`` (or None).
        **overrides: config fields of the multi-agent env (``num_cars``, ``render_mode``, ...).
    """

    metadata = {"render_modes": ["human", "rgb_array"], "render_fps": 4}

    def __init__(self, env_id: str, background: Optional[str] = None, fallback: str = "rule",
                 shipped: Optional[str] = None, **overrides: Any) -> None:
        policy, name, settings = _background(env_id, background, fallback, shipped)
        self.background_name = name
        self.parallel = make_parallel(env_id, **{**settings, **overrides})
        if EGO not in self.parallel.possible_agents:
            raise ValueError(f"{env_id} has no {EGO}")
        self._scripted = name if isinstance(policy, type) else None  # rebuilt per seed at reset
        self.background = policy(self.parallel) if isinstance(policy, type) else policy
        self.observation_space = self.parallel.observation_space(EGO)
        self.action_space = self.parallel.action_space(EGO)
        self.render_mode = self.parallel.render_mode
        self.metadata = {**self.metadata, "render_fps": self.parallel.config.render_fps}
        self._others: dict[str, np.ndarray] = {}

    def reset(self, *, seed: Optional[int] = None, options: Optional[dict] = None):
        from box2d_driving.envs.base import check_reset_arguments

        seed, options = check_reset_arguments(seed, options)
        super().reset(seed=seed)
        if seed is not None:
            self.action_space.seed(seed)
        obs, infos = self.parallel.reset(seed=seed, options=options)
        if self._scripted is not None and seed is not None:  # e.g. a random background: seeded too
            from box2d_driving.policies import make_policy

            self.background = make_policy(self._scripted, self.parallel, seed=seed)
        self._others = {a: o for a, o in obs.items() if a != EGO}
        return obs[EGO], infos[EGO]

    def step(self, action: Any):
        if EGO not in self.parallel.agents:
            raise RuntimeError("step() after the episode ended: call reset()")
        actions = dict(self.background.act(self._others)) if self._others else {}
        actions[EGO] = action
        obs, rewards, terms, truncs, infos = self.parallel.step(actions)
        self._others = {a: o for a, o in obs.items() if a != EGO and a in self.parallel.agents}
        return obs[EGO], rewards[EGO], terms[EGO], truncs[EGO], infos[EGO]

    def render(self):
        return self.parallel.render()

    def close(self) -> None:
        self.parallel.close()


def _background(env_id: str, background: Optional[str], fallback: str, shipped: Optional[str]):
    """(policy or scripted class, its name, env settings it needs)."""
    from box2d_driving.policies import SCRIPTED

    if background in SCRIPTED:
        return SCRIPTED[background], background, {}
    if background is not None:
        if not Path(background).exists():
            raise ValueError(f"background {background!r}: not a scripted policy ({', '.join(SCRIPTED)}) "
                             f"and no trained policy at that path")
        policy = _load(Path(background))
        return policy, str(background), _observation_settings(policy)
    if shipped is not None and (SHIPPED / shipped).is_dir():
        policy = _load(SHIPPED / shipped)
        return policy, f"shipped:{shipped}", _observation_settings(policy)
    if shipped is not None:  # an install without the shipped policies: another world, said aloud
        warnings.warn(f"{env_id}: the shipped background policy {shipped!r} is not in {SHIPPED}; the other cars "
                      f"are driven by the scripted {fallback!r} policy instead", stacklevel=3)
    return SCRIPTED[fallback], fallback, {}


def _load(path: Path) -> Any:
    """A trained policy run with numpy (:func:`box2d_driving.policies.load_trained`): the base
    install drives the background cars with it, no training extra needed."""
    from box2d_driving.policies import load_trained

    return load_trained(path)


def _observation_settings(policy: Any) -> dict:
    """The trained background's observation settings, and its light convention for drawing (the
    other cars stop on the value drawn red)."""
    settings = {k: v for k, v in policy.env_overrides.items() if k not in _YOURS}
    if getattr(policy, "stop_value", None) is not None:
        settings["render_stop_value"] = policy.stop_value
    return settings


def register_single_agent_envs() -> None:
    """Register the ``box2d_driving/...`` Gymnasium ids (done on ``import box2d_driving``): each
    scenario record's ``single_agent`` id is registered with its record."""
    from box2d_driving.scenarios import scenarios

    scenarios()
