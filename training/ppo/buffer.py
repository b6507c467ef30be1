"""A rollout buffer that keeps padding out of PPO's loss and stores each car's observation once.

Padding transitions (a car's slot after its trajectory ended, until its env instance resets) are
recognised by the alive flag the :class:`training.ppo.vec_env.SlotVecEnv` writes into every slot
observation. They stay in the buffer, so GAE runs over the arrays as SB3 lays them out (a slot's
real last step is cut from what follows by its ``done``), but :meth:`get` yields only real
transitions, so padding never reaches the policy loss, the value loss, the entropy bonus or the
per-minibatch advantage normalisation.

A slot observation carries the team block (every car of its instance, see
:class:`training.ppo.slots.TeamLayout`), which is the instance's own observations again. The buffer
keeps only each slot's own observation and alive flag (``N + 1`` times less memory and copying)
and rebuilds what the policy reads:

* ``group_size = 1`` (minibatches of single transitions): the full slot observation, team block
  rebuilt from the stored rows of the same instance and step;
* ``group_size = N`` (the cars per instance; minibatches drawn by env step): the live cars of one
  instance at one step sit next to each other and are never split between minibatches, and each
  row is *packed* as ``[own observation (D) | group number]`` (see
  :meth:`training.ppo.policy.CTDENetwork.forward`): the centralised critic averages the encodings of
  the rows of a group, which are exactly the team's live cars, so the team is encoded once per
  step with the actor's encoder pass instead of once per car. Each car's transition is still
  used exactly once per epoch.
"""

from __future__ import annotations

from typing import Generator, Optional

import numpy as np
from stable_baselines3.common.buffers import RolloutBuffer
from stable_baselines3.common.type_aliases import RolloutBufferSamples

from training.ppo.original_update import KLWatch, normalise_per_car
from training.ppo.slots import TeamLayout


def discounted_returns(rewards: np.ndarray, episode_starts: np.ndarray, last_values: np.ndarray,
                       dones: np.ndarray, gamma: float) -> np.ndarray:
    """Discounted rewards-to-go ``R_t = r_t + gamma * R_{t+1}`` of a rollout laid out ``(T, E)``
    as SB3's buffer holds it: the sum stops where an episode ends (``episode_starts[t + 1]``, or
    ``dones`` after the last step) and is bootstrapped with ``last_values`` where the rollout cuts
    an episode short. The same as GAE's lambda-returns with ``gae_lambda = 1``."""
    returns = np.empty_like(rewards)
    following = last_values * (1.0 - dones)
    for t in reversed(range(len(rewards))):
        if t < len(rewards) - 1:
            following = returns[t + 1] * (1.0 - episode_starts[t + 1])
        returns[t] = rewards[t] + gamma * following
    return returns


class MaskedRolloutBuffer(RolloutBuffer):
    """:class:`RolloutBuffer` of slot observations (``layout``) whose minibatches contain only
    live transitions (own alive flag set)."""

    def __init__(self, *args, layout: TeamLayout, group_size: int = 1, per_car_advantages: bool = False,
                 returns_to_go: bool = False, **kwargs) -> None:
        self.layout = layout
        self.group_size = group_size
        self.per_car_advantages = per_car_advantages  # normalise per car index over the update
        self.returns_to_go = returns_to_go  # value targets: discounted rewards-to-go (the paper's code)
        self.kl_watch: Optional[KLWatch] = None  # for the paper's KL rule
        super().__init__(*args, **kwargs)

    def reset(self) -> None:
        self.obs_shape = (self.layout.obs_dim + 1,)  # own observation and own alive flag
        self.mask = np.zeros((self.buffer_size, self.n_envs), dtype=bool)
        super().reset()
        # The observations (tens of MB) keep their memory from update to update: SB3 allocates
        # them anew, and a fresh block that large comes from the OS page by page as the rollout
        # first writes it (on a VM about half a second an update of 32,000 decisions).
        kept = self.__dict__.get("_kept_observations")
        if kept is not None and kept.shape == self.observations.shape:
            kept.fill(0)
            self.observations = kept
        self._kept_observations = self.observations

    def add(self, obs: np.ndarray, *args, **kwargs) -> None:  # type: ignore[override]
        obs = np.asarray(obs)
        lay = self.layout
        self.mask[self.pos] = obs[:, lay.self_alive] > 0.5
        compact = np.concatenate([obs[:, lay.own], obs[:, lay.self_alive:lay.self_alive + 1]], axis=1)
        super().add(compact, *args, **kwargs)

    def compute_returns_and_advantage(self, last_values, dones: np.ndarray) -> None:
        """SB3's GAE advantages; the value targets are SB3's lambda-returns (advantage + value)
        or, with ``returns_to_go``, the discounted rewards-to-go the paper's code trains its critic
        on (:func:`discounted_returns`, bootstrapped with ``last_values`` where the rollout cuts an
        episode)."""
        super().compute_returns_and_advantage(last_values, dones)
        if self.returns_to_go:
            self.returns = discounted_returns(self.rewards, self.episode_starts,
                                              last_values.clone().cpu().numpy().flatten(),
                                              np.asarray(dones, dtype=np.float32), self.gamma)

    @property
    def n_valid(self) -> int:
        return int(self.mask.sum())

    def get(self, batch_size: Optional[int] = None) -> Generator[RolloutBufferSamples, None, None]:
        assert self.full, "the rollout buffer is not full"
        if not self.generator_ready:  # the update's first pass
            if self.per_car_advantages:
                self.advantages = normalise_per_car(self.advantages, self.mask, self.layout.n_cars)
            if self.kl_watch is not None:
                self.kl_watch.start_update()
            # SB3 copies each array into slot-major order here (slot, step); the arrays stay in
            # the order they were filled (step, slot), flattened without a copy, and a minibatch's
            # slot-major indices are mapped onto them (:meth:`_stored`): the same transitions in
            # the same order as SB3's layout gives, without copying the observations every update
            for name in ("observations", "actions", "values", "log_probs", "advantages", "returns"):
                array = self.__dict__[name]
                self.__dict__[name] = array.reshape(self.buffer_size * self.n_envs, *array.shape[2:])
            self.flat_mask = self.mask.swapaxes(0, 1).reshape(-1)  # slot-major, as minibatches are drawn
            self.generator_ready = True
        if self.group_size == 1:
            valid = np.flatnonzero(self.flat_mask)
            indices = valid[np.random.permutation(len(valid))]
            batch_size = batch_size or len(indices)
            for start in range(0, len(indices), batch_size):
                yield self._get_samples(indices[start:start + batch_size])
            return
        rows, sizes = self._shuffled_groups()
        ends = np.cumsum(sizes)  # row count at the end of each group
        batch_size = batch_size or len(rows)
        start, first = 0, 0
        while start < len(rows):  # cut after the group that reaches batch_size rows
            last = int(np.searchsorted(ends, start + batch_size, side="left"))
            last = min(last, len(sizes) - 1)
            stop = int(ends[last])
            yield self._packed_samples(rows[start:stop], sizes[first:last + 1])
            start, first = stop, last + 1

    def _shuffled_groups(self) -> tuple[np.ndarray, np.ndarray]:
        """Flat indices of the live transitions, whole env steps in random order (slot ``k * N
        + i`` at step ``t`` is flat index ``slot * T + t``), and the live cars of each step."""
        n, steps = self.group_size, self.buffer_size
        if self.n_envs % n:
            raise ValueError(f"group_size {n} does not divide the {self.n_envs} slots")
        groups = np.random.permutation((self.n_envs // n) * steps)
        instance, t = np.divmod(groups, steps)
        flat = (instance[:, None] * n + np.arange(n)[None, :]) * steps + t[:, None]  # (G, N)
        live = self.flat_mask[flat]
        sizes = live.sum(axis=1)
        return flat[live], sizes[sizes > 0]

    def _stored(self, batch_inds: np.ndarray) -> np.ndarray:
        """Where slot-major indices (``slot * T + t``, SB3's flattened layout) sit in the
        flattened arrays, which keep the order they were filled in (``t * n_envs + slot``)."""
        slot, t = np.divmod(batch_inds, self.buffer_size)
        return t * self.n_envs + slot

    def _team_rows(self, batch_inds: np.ndarray) -> np.ndarray:
        """Full slot observations of ``batch_inds``: own row, the team block and alive flags
        rebuilt from the stored rows of the same instance and step."""
        steps, n = self.buffer_size, self.layout.n_cars
        slot, t = np.divmod(batch_inds, steps)
        mates = ((slot // n * n)[:, None] + np.arange(n)[None, :]) * steps + t[:, None]  # (B, N)
        team = self.observations[self._stored(mates)]  # (B, N, D + 1)
        own = self.observations[self._stored(batch_inds)]
        return np.concatenate([own[:, :-1], team[..., :-1].reshape(len(batch_inds), -1),
                               team[..., -1], own[:, -1:]], axis=1)

    def _samples(self, obs: np.ndarray, batch_inds: np.ndarray) -> RolloutBufferSamples:
        stored = self._stored(batch_inds)
        data = (obs, self.actions[stored].astype(np.float32, copy=False),
                self.values[stored].flatten(), self.log_probs[stored].flatten(),
                self.advantages[stored].flatten(), self.returns[stored].flatten())
        samples = RolloutBufferSamples(*tuple(map(self.to_torch, data)))
        if self.kl_watch is not None:
            self.kl_watch.minibatch(samples.old_log_prob)
        return samples

    def _get_samples(self, batch_inds: np.ndarray, env=None) -> RolloutBufferSamples:
        return self._samples(self._team_rows(batch_inds), batch_inds)

    def _packed_samples(self, batch_inds: np.ndarray, sizes: np.ndarray) -> RolloutBufferSamples:
        obs = self.observations[self._stored(batch_inds)]  # (B, D + 1): the alive column becomes the group
        obs[:, -1] = np.repeat(np.arange(len(sizes), dtype=np.float32), sizes)
        return self._samples(obs, batch_inds)
