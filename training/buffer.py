"""A rollout buffer that keeps padding out of PPO's loss.

Padding transitions (a car's slot after its trajectory ended, until its env instance resets) are
recognised by the alive flag the :class:`training.vec_env.SlotVecEnv` writes into every slot
observation. They stay in the buffer, so GAE runs over the arrays as SB3 lays them out (a slot's
real last step is cut from what follows by its ``done``), but :meth:`get` yields only real
transitions, so padding never reaches the policy loss, the value loss, the entropy bonus or the
per-minibatch advantage normalisation.

With ``group_size = N`` (the cars per env instance) minibatches are drawn by env step instead of
by transition: the live cars of one instance at one step sit next to each other, so the
centralised critic, whose input (the team block) is the same for all of them, encodes the team
once per step instead of once per car (:meth:`training.policy.CTDENetwork.forward_critic`
skips consecutive repeats). About N times less critic work; each car's transition is still used
exactly once per epoch.
"""

from __future__ import annotations

from typing import Generator, Optional

import numpy as np
from stable_baselines3.common.buffers import RolloutBuffer
from stable_baselines3.common.type_aliases import RolloutBufferSamples


class MaskedRolloutBuffer(RolloutBuffer):
    """:class:`RolloutBuffer` whose minibatches contain only transitions with
    ``obs[alive_index] > 0.5``."""

    def __init__(self, *args, alive_index: int, group_size: int = 1, **kwargs) -> None:
        self.alive_index = alive_index
        self.group_size = group_size
        super().__init__(*args, **kwargs)

    def reset(self) -> None:
        self.mask = np.zeros((self.buffer_size, self.n_envs), dtype=bool)
        super().reset()

    def add(self, obs: np.ndarray, *args, **kwargs) -> None:  # type: ignore[override]
        self.mask[self.pos] = np.asarray(obs)[:, self.alive_index] > 0.5
        super().add(obs, *args, **kwargs)

    @property
    def n_valid(self) -> int:
        return int(self.mask.sum())

    def get(self, batch_size: Optional[int] = None) -> Generator[RolloutBufferSamples, None, None]:
        assert self.full, "the rollout buffer is not full"
        if not self.generator_ready:
            for name in ("observations", "actions", "values", "log_probs", "advantages", "returns"):
                self.__dict__[name] = self.swap_and_flatten(self.__dict__[name])
            self.flat_mask = self.mask.swapaxes(0, 1).reshape(-1)
            self.generator_ready = True
        indices = self._shuffled_valid()
        batch_size = batch_size or len(indices)
        for start in range(0, len(indices), batch_size):
            yield self._get_samples(indices[start:start + batch_size])

    def _shuffled_valid(self) -> np.ndarray:
        """Flat indices of the live transitions in random order; with ``group_size > 1``, whole
        env steps in random order (slot ``k * N + i`` at step ``t`` is flat index ``slot * T + t``)."""
        n, steps = self.group_size, self.buffer_size
        if n == 1:
            valid = np.flatnonzero(self.flat_mask)
            return valid[np.random.permutation(len(valid))]
        if self.n_envs % n:
            raise ValueError(f"group_size {n} does not divide the {self.n_envs} slots")
        groups = np.random.permutation((self.n_envs // n) * steps)
        instance, t = np.divmod(groups, steps)
        flat = ((instance[:, None] * n + np.arange(n)[None, :]) * steps + t[:, None]).reshape(-1)
        return flat[self.flat_mask[flat]]
