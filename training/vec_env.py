"""One SB3 ``VecEnv`` slot per car: the parameter-shared multi-agent env as a batch of
single-agent transitions, with done on the right step and the team block for the critic.

Why not SuperSuit (see ``docs/training.md``): its ``pettingzoo_env_to_vec_env_v1`` refuses envs
whose agents finish at different times unless ``black_death_v3`` pads them, and ``black_death_v3``
ends episodes on ``terminated AND truncated``, never reports an agent's own termination and steps
the env with ``{}`` once every agent is gone; SB3 would also see truncations as terminations and
cannot seed it. This class does the same job in one place, correctly:

* slot ``k * N + i`` is car ``i`` of env instance ``k``;
* a car's slot reports ``done`` on exactly the decision its trajectory ends, with its real last
  observation in ``infos[slot]["terminal_observation"]`` and ``"TimeLimit.truncated"`` set when the
  horizon (not a goal or a crash) ended it;
* after that the slot emits padding (zero observation, zero reward, alive flag 0) until every car
  of the instance is done and the instance resets; :class:`training.buffer.MaskedRolloutBuffer`
  keeps padding out of the loss and the advantage normalisation;
* each observation carries a team block, the observations of every car of the same instance and
  their alive mask, so the centralised critic sees the team while PPO shuffles single transitions
  (the actor is built blind to it).

Layout of a slot observation (``TeamLayout``): ``[own obs (D) | team obs (N x D) | alive (N) |
own alive (1)]``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Callable, Optional, Sequence

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from stable_baselines3.common.vec_env.base_vec_env import VecEnv


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


class CarSlots:
    """The ``VecEnv`` plumbing shared by every one-slot-per-car vector env: slot ``k * N + i`` is
    car ``i`` of instance ``self.envs[k]`` (needs ``envs`` and ``n_cars``)."""

    envs: list
    n_cars: int

    def close(self) -> None:
        for e in self.envs:
            e.close()

    def _instances(self, indices) -> list[int]:
        return sorted({i // self.n_cars for i in self._get_indices(indices)})

    def get_attr(self, attr_name: str, indices=None) -> list[Any]:
        return [getattr(self.envs[i // self.n_cars], attr_name) for i in self._get_indices(indices)]

    def set_attr(self, attr_name: str, value: Any, indices=None) -> None:
        for k in self._instances(indices):
            setattr(self.envs[k], attr_name, value)

    def env_method(self, method_name: str, *args, indices=None, **kwargs) -> list[Any]:
        return [getattr(self.envs[i // self.n_cars], method_name)(*args, **kwargs)
                for i in self._get_indices(indices)]

    def env_is_wrapped(self, wrapper_class: type[gym.Wrapper], indices=None) -> list[bool]:
        return [False for _ in self._get_indices(indices)]


class SlotVecEnv(CarSlots, VecEnv):
    """``len(env_fns) * num_cars`` slots over parameter-shared driving envs (one process)."""

    def __init__(self, env_fns: Sequence[Callable[[], Any]]) -> None:
        self.envs = [fn() for fn in env_fns]
        first = self.envs[0]
        self.agents = list(first.possible_agents)
        self.n_cars = len(self.agents)
        for e in self.envs[1:]:
            if list(e.possible_agents) != self.agents:
                raise ValueError("all env instances must have the same agents")
        base_space = first.observation_space(self.agents[0])
        self.layout = TeamLayout(int(np.prod(base_space.shape)), self.n_cars)
        super().__init__(len(self.envs) * self.n_cars, slot_observation_space(base_space, self.n_cars),
                         first.action_space(self.agents[0]))
        self._obs = np.zeros((self.num_envs, self.layout.size), dtype=np.float32)
        self._actions: Optional[np.ndarray] = None

    # -- helpers ------------------------------------------------------------------------------
    def _write_instance(self, k: int, obs: dict[str, np.ndarray], out: np.ndarray) -> None:
        """Slot observations of instance ``k`` from the agents' observation dict (padding for
        agents absent from ``obs``) into ``out`` rows ``k*N .. k*N+N-1``."""
        lay, n = self.layout, self.n_cars
        rows = out[k * n:(k + 1) * n]
        rows[:] = 0.0
        team = np.zeros((n, lay.obs_dim), dtype=np.float32)
        alive = np.zeros(n, dtype=np.float32)
        for i, agent in enumerate(self.agents):
            if agent in obs:
                team[i] = obs[agent]
                alive[i] = 1.0
        rows[:, lay.team] = team.reshape(-1)
        rows[:, lay.alive] = alive
        rows[:, lay.own] = team
        rows[:, lay.self_alive] = alive

    def _reset_instance(self, k: int, seed: Optional[int]) -> dict[str, np.ndarray]:
        options = self._options[k * self.n_cars]
        obs, _ = self.envs[k].reset(seed=seed, **({"options": options} if options else {}))
        return obs

    # -- VecEnv API ---------------------------------------------------------------------------
    def reset(self):
        for k in range(len(self.envs)):
            obs = self._reset_instance(k, self._seeds[k * self.n_cars])
            self._write_instance(k, obs, self._obs)
        self._reset_seeds()
        self._reset_options()
        return self._obs.copy()

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = np.asarray(actions).reshape(self.num_envs)

    def step_wait(self):
        n = self.n_cars
        rewards = np.zeros(self.num_envs, dtype=np.float32)
        dones = np.zeros(self.num_envs, dtype=bool)
        infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]  # distinct dicts
        final = np.zeros((n, self.layout.size), dtype=np.float32)
        for k, env in enumerate(self.envs):
            acts = {a: int(self._actions[k * n + i]) for i, a in enumerate(self.agents)
                    if a in env.agents}
            obs, rew, term, trunc, info = env.step(acts)
            self._write_instance(0, obs, final)
            for i, agent in enumerate(self.agents):
                if agent not in obs:
                    continue
                slot = k * n + i
                rewards[slot] = rew[agent]
                slot_info = dict(info[agent])
                if term[agent] or trunc[agent]:
                    dones[slot] = True
                    slot_info["terminal_observation"] = final[i].copy()
                    slot_info["TimeLimit.truncated"] = bool(trunc[agent] and not term[agent])
                infos[slot] = slot_info
            if env.agents:
                live = {a: o for a, o in obs.items() if a in env.agents}
                self._write_instance(k, live, self._obs)
            else:
                self._write_instance(k, self._reset_instance(k, None), self._obs)
        return self._obs.copy(), rewards, dones, infos


def make_slot_vec_env(env_id: str, n_envs: int, **overrides: Any) -> SlotVecEnv:
    """``n_envs`` instances of a registered env as one :class:`SlotVecEnv`."""
    import box2d_driving

    return SlotVecEnv([lambda: box2d_driving.make(env_id, **overrides) for _ in range(n_envs)])
