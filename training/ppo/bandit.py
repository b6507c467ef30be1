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

from box2d_driving.envs.core import step_instances
from training.ppo.slots import checked_actions
from training.ppo.vec_env import CarSlots

AccelPolicy = Callable[[np.ndarray], np.ndarray]


class SplineBanditVecEnv(CarSlots, VecEnv):
    """``len(env_fns) * num_cars`` one-step slots over spline envs (one process)."""

    def __init__(self, env_fns: Sequence[Callable[[], Any]], accel_policy: AccelPolicy,
                 normalise: bool = True) -> None:
        self.instances = [fn() for fn in env_fns]  # the spline envs (``envs``)
        first = self.instances[0]
        if not hasattr(first, "plan"):
            raise ValueError(f"{type(first).__name__} has no spline stage (use a *-spline-v0 env)")
        self.agents = list(first.possible_agents)
        self.n_cars = len(self.agents)
        self._car = {a: i for i, a in enumerate(self.agents)}
        self.accel_policy = accel_policy
        self.normalise = normalise
        super().__init__(len(self.instances) * self.n_cars, first.spline_observation_space,
                         first.spline_action_space)
        self._obs = np.zeros((self.num_envs,) + first.spline_observation_space.shape, dtype=np.float32)
        self._actions: Optional[np.ndarray] = None

    @property
    def envs(self) -> list:
        """The spline env instances, one per ``n_cars`` slots."""
        return self.instances

    def _plan(self, k: int, seed: Optional[int]) -> None:
        obs0 = self.instances[k].plan(seed)
        n = self.n_cars
        self._obs[k * n:(k + 1) * n] = np.stack([obs0[a] for a in self.agents])

    # -- VecEnv API ---------------------------------------------------------------------------
    def reset(self) -> np.ndarray:
        for k in range(len(self.instances)):
            self._plan(k, self._seeds[k * self.n_cars])
        self._reset_seeds()
        self._reset_options()
        return self._obs.copy()

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = np.asarray(actions)

    def step_wait(self):
        returns, outcome, lane_sum, lane_count = self._inner_episodes(
            self._actions.reshape((len(self.instances), self.n_cars) + self.action_space.shape))
        rewards = returns.copy()
        if self.normalise:
            rewards = (returns - returns.mean()) / (returns.std() + 1e-8)
        with np.errstate(invalid="ignore", divide="ignore"):
            lane = lane_sum / lane_count
        infos_out = [{"episode_return": float(returns[s]), "arrived": bool(outcome[s, 0]),
                      "collided": bool(outcome[s, 1]), "junction_lane_position": float(lane[s]),
                      "terminal_observation": self._obs[s].copy(), "TimeLimit.truncated": False}
                     for s in range(self.num_envs)]
        for k in range(len(self.instances)):
            self._plan(k, None)
        return self._obs.copy(), rewards.astype(np.float32), np.ones(self.num_envs, dtype=bool), infos_out

    def _inner_episodes(self, actions: np.ndarray) -> tuple[np.ndarray, ...]:
        """Every instance's inner episode on the paths ``actions[k]`` pick, the acceleration
        policy deciding for the live cars of all instances at once. Returns per slot the sum of
        its rewards, (arrived, collided) at its end, and the sum and count of its lane positions
        in the junction.

        Each decision steps every instance with live cars through one env-core call
        (:func:`~box2d_driving.envs.core.step_instances`: the numpy work of all their cars
        together, not once per instance behind the PettingZoo dicts); what a car gets does not
        depend on which instances are stepped with it, so the returns are those of stepping each
        instance on its own (``tests/test_bilevel.py`` checks them bit for bit)."""
        n = self.n_cars
        returns = np.zeros(self.num_envs)
        lane_sum = np.zeros(self.num_envs)
        lane_count = np.zeros(self.num_envs)
        outcome = np.zeros((self.num_envs, 2), dtype=bool)  # arrived, collided
        obs_now: list[np.ndarray] = []  # per instance: its live cars' observations, in agent order
        for k, env in enumerate(self.instances):
            obs, infos = env.reset(options={"use_plan": True, "spline_actions": actions[k]})
            obs_now.append(np.stack([obs[a] for a in env.agents]))
            self._lane_stats(k, [self._car[a] for a in infos], list(infos.values()), lane_sum, lane_count)
        n_actions = self.instances[0].action_space(self.agents[0]).n
        while True:
            live = [k for k, env in enumerate(self.instances) if env.agents]
            if not live:
                break
            acts = np.asarray(self.accel_policy(np.concatenate([obs_now[k] for k in live])))
            counts = [len(obs_now[k]) for k in live]
            raws = [checked_actions(a, n_actions) for a in np.split(acts, np.cumsum(counts)[:-1])]
            for k, d in zip(live, step_instances([self.instances[k] for k in live], raws)):
                slots = k * n + d.cars
                returns[slots] += d.rewards
                ended = np.ones(len(d.cars), dtype=bool) if d.truncated else d.terminated
                for j in np.flatnonzero(ended).tolist():
                    outcome[slots[j]] = (d.infos[j]["arrived"], d.infos[j]["collided"])
                self._lane_stats(k, d.cars.tolist(), d.infos, lane_sum, lane_count)
                obs_now[k] = d.observations[~d.terminated]
        return returns, outcome, lane_sum, lane_count

    def _lane_stats(self, k: int, cars: Sequence[int], infos: Sequence[dict], lane_sum: np.ndarray,
                    lane_count: np.ndarray) -> None:
        """Adds the lane positions of instance ``k``'s ``cars`` that are in the junction."""
        for car, info in zip(cars, infos):
            if info.get("in_junction") and info.get("lane_offset") is not None:
                slot = k * self.n_cars + car
                lane_sum[slot] += info["lane_offset"]
                lane_count[slot] += 1
