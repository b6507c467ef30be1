"""The spline stage as a one-step env (the paper's bilevel scheme: the spline stage as a one-step bandit).

:class:`SplineBanditVecEnv` has one slot per car of ``len(env_fns)`` spline-env instances. Its
observation is each car's stage-0 observation; ``step(actions)`` builds the paths those actions
pick, runs the whole inner episode with the acceleration policy (greedy by default, batched over
every live car of every instance) and returns, per car, the undiscounted sum of its inner rewards;
every slot is done after that one step and the next episodes are planned. PPO on it is
single-step PPO: the advantage is the (normalised) reward minus a learned baseline, never
bootstrapped, so gamma and lambda do not matter.

Reward normalisation (``normalise=True``, the paper's): the returns of one step (all cars of all
instances) are standardised, ``(R - mean) / (std + 1e-8)``. The raw return is in
``infos[slot]["episode_return"]``, with the car's outcome and its mean lane position in the
junction, for logging.

The acceleration policy is a callable ``(M, D) own observations -> (M,) actions``; the bilevel
trainer passes one bound to the live PPO policy object, so it always uses the latest weights (one
process: nothing to refresh or copy).
"""

from __future__ import annotations

from typing import Any, Callable, Optional, Sequence

import numpy as np
from stable_baselines3.common.vec_env.base_vec_env import VecEnv

from training.ppo.vec_env import CarSlots

AccelPolicy = Callable[[np.ndarray], np.ndarray]


class SplineBanditVecEnv(CarSlots, VecEnv):
    """``len(env_fns) * num_cars`` one-step slots over spline envs (one process)."""

    def __init__(self, env_fns: Sequence[Callable[[], Any]], accel_policy: AccelPolicy,
                 normalise: bool = True) -> None:
        self.envs = [fn() for fn in env_fns]
        first = self.envs[0]
        if not hasattr(first, "plan"):
            raise ValueError(f"{type(first).__name__} has no spline stage (use a *-spline-v0 env)")
        self.agents = list(first.possible_agents)
        self.n_cars = len(self.agents)
        self._car = {a: i for i, a in enumerate(self.agents)}
        self.accel_policy = accel_policy
        self.normalise = normalise
        super().__init__(len(self.envs) * self.n_cars, first.spline_observation_space,
                         first.spline_action_space)
        self._obs = np.zeros((self.num_envs,) + first.spline_observation_space.shape, dtype=np.float32)
        self._actions: Optional[np.ndarray] = None

    def _plan(self, k: int, seed: Optional[int]) -> None:
        obs0 = self.envs[k].plan(seed)
        n = self.n_cars
        self._obs[k * n:(k + 1) * n] = np.stack([obs0[a] for a in self.agents])

    # -- VecEnv API ---------------------------------------------------------------------------
    def reset(self) -> np.ndarray:
        for k in range(len(self.envs)):
            self._plan(k, self._seeds[k * self.n_cars])
        self._reset_seeds()
        self._reset_options()
        return self._obs.copy()

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = np.asarray(actions)

    def step_wait(self):
        n = self.n_cars
        shape = (len(self.envs), n) + self.action_space.shape
        actions = self._actions.reshape(shape)
        returns = np.zeros(self.num_envs)
        obs_now: list[dict[str, np.ndarray]] = []
        lane_sum = np.zeros(self.num_envs)
        lane_count = np.zeros(self.num_envs)
        outcome = np.zeros((self.num_envs, 2), dtype=bool)  # arrived, collided
        for k, env in enumerate(self.envs):
            obs, infos = env.reset(options={"use_plan": True, "spline_actions": actions[k]})
            obs_now.append(obs)
            self._lane_stats(k, infos, lane_sum, lane_count)
        while any(env.agents for env in self.envs):
            live = [(k, a) for k, env in enumerate(self.envs) for a in env.agents]
            acts = self.accel_policy(np.stack([obs_now[k][a] for k, a in live]))
            per_env: list[dict[str, int]] = [{} for _ in self.envs]
            for (k, a), act in zip(live, acts):
                per_env[k][a] = int(act)
            for k, env in enumerate(self.envs):
                if not env.agents:
                    continue
                obs, rew, term, trunc, infos = env.step(per_env[k])
                obs_now[k] = obs
                for a, r in rew.items():
                    slot = k * n + self._car[a]
                    returns[slot] += r
                    if term[a] or trunc[a]:
                        outcome[slot] = (infos[a]["arrived"], infos[a]["collided"])
                self._lane_stats(k, infos, lane_sum, lane_count)
        rewards = returns.copy()
        if self.normalise:
            rewards = (returns - returns.mean()) / (returns.std() + 1e-8)
        with np.errstate(invalid="ignore", divide="ignore"):
            lane = lane_sum / lane_count
        infos_out = [{"episode_return": float(returns[s]), "arrived": bool(outcome[s, 0]),
                      "collided": bool(outcome[s, 1]), "junction_lane_position": float(lane[s]),
                      "terminal_observation": self._obs[s].copy(), "TimeLimit.truncated": False}
                     for s in range(self.num_envs)]
        for k in range(len(self.envs)):
            self._plan(k, None)
        return self._obs.copy(), rewards.astype(np.float32), np.ones(self.num_envs, dtype=bool), infos_out

    def _lane_stats(self, k: int, infos: dict, lane_sum: np.ndarray, lane_count: np.ndarray) -> None:
        for a, info in infos.items():
            if info.get("in_junction") and info.get("lane_offset") is not None:
                slot = k * self.n_cars + self._car[a]
                lane_sum[slot] += info["lane_offset"]
                lane_count[slot] += 1
