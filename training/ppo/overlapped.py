"""PPO whose rollouts keep the env workers and the learner busy at the same time.

SB3's ``collect_rollouts`` does one thing at a time at every step: the policy's forward pass, then
the env step (the worker processes busy, the learner waiting), then the step's bookkeeping
(callbacks, the timeout values, the rollout buffer; the workers idle). :class:`OverlappedPPO`
overrides that extension point so that, once a step's results are in, the learner draws the next
step's actions and hands them to the workers first, and only then, while the workers step:

* finishes the next step's values (the critic's half of the forward pass,
  :meth:`training.ppo.policy.CTDEPolicy.rollout_values`);
* files the step that came in: ``callback.on_step``, the bootstrapped values of cars the horizon
  stopped, ``rollout_buffer.add``.

Nothing is computed with other weights or on other rows than in SB3's loop: the policy's lean
forward pass is those same two halves called back to back, the update stays SB3's and runs
between rollouts, and each rollout's last step is not sent ahead (its actions come from the
weights after the update). So the rollouts, and with fixed threads the weights, are the same bit
for bit as with SB3's loop, for any number of workers (``tests/test_overlapped.py``). Two things
differ, both outside the rollouts: ``callback.on_step`` for a step runs after the next step's
actions were drawn (a callback that changes the policy mid-rollout would act one step later), and
a callback that stops training leaves the envs one step further than the buffer shows.

Why not split the instances into two groups, one stepping while the policy runs on the other
(Sample Factory's double buffering)? Then every forward pass runs on half the rows, and the
matrix-product kernels pick their blocking by row count: measured here, a 256-wide linear layer
on 8 + 8 rows differs from the same 16 rows at once in the last bit. Rollouts could no longer be
those of the plain loop. This loop overlaps what can be overlapped without that.

Used when the env steps in worker processes (``--num-cpus`` >= 1) and the policy takes the lean
forward pass; otherwise (and with ``TrainConfig.overlap`` off) SB3's own loop runs.
"""

from __future__ import annotations

from typing import Any, Optional, cast

import numpy as np
import torch as th
from stable_baselines3 import PPO
from stable_baselines3.common.buffers import RolloutBuffer
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.utils import obs_as_tensor
from stable_baselines3.common.vec_env import VecEnv

from training.ppo.policy import CTDEPolicy


class OverlappedPPO(PPO):
    """SB3 ``PPO`` with the overlapped rollout loop of this module (``overlap = False``: SB3's)."""

    overlap: bool = True
    # torch threads while collecting rollouts and during the update (None: as already set): the
    # env workers wait for the next rollout while the learner updates, so the update can use
    # their cores without the forward pass competing with them during the rollout
    rollout_threads: Optional[int] = None
    update_threads: Optional[int] = None

    def overlaps(self, env: VecEnv) -> bool:
        """Whether ``collect_rollouts`` on ``env`` takes the overlapped loop."""
        policy = self.policy
        return (self.overlap and getattr(env, "worker_processes", 0) > 0 and not self.use_sde
                and isinstance(policy, CTDEPolicy) and policy.lean_rollouts_available())

    def train(self) -> None:
        if self.update_threads is not None:
            th.set_num_threads(self.update_threads)
        super().train()

    def collect_rollouts(self, env: VecEnv, callback: BaseCallback, rollout_buffer: RolloutBuffer,
                         n_rollout_steps: int) -> bool:
        if self.rollout_threads is not None:
            th.set_num_threads(self.rollout_threads)
        if not self.overlaps(env):
            return super().collect_rollouts(env, callback, rollout_buffer, n_rollout_steps)
        return self._collect_overlapped(env, callback, rollout_buffer, n_rollout_steps)

    def _collect_overlapped(self, env: VecEnv, callback: BaseCallback, rollout_buffer: RolloutBuffer,
                            n_rollout_steps: int) -> bool:
        assert self._last_obs is not None, "no observation to start the rollout from"
        self.policy.set_training_mode(False)
        rollout_buffer.reset()
        callback.on_rollout_start()
        ahead: Optional[tuple] = self._act(env, cast(np.ndarray, self._last_obs))
        for n_steps in range(1, n_rollout_steps + 1):
            sent = ahead
            assert sent is not None
            stepped = env.step_wait()
            new_obs, rewards, dones, infos = cast(np.ndarray, stepped[0]), *stepped[1:]
            self.num_timesteps += env.num_envs
            # the next step goes to the workers before this one is filed, except the
            # rollout's last: its actions come from the weights after the update
            ahead = self._act(env, new_obs) if n_steps < n_rollout_steps else None
            if not self._file(callback, rollout_buffer, sent, new_obs, rewards, dones, infos, n_steps):
                if ahead is not None:
                    env.step_wait()  # the step in flight: the run stops, its results unused
                return False
        with th.no_grad():
            last_values = self.policy.predict_values(obs_as_tensor(new_obs, self.device))
        rollout_buffer.compute_returns_and_advantage(last_values=last_values, dones=dones)
        callback.update_locals({"new_obs": new_obs, "dones": dones, "infos": infos, "values": last_values,
                                "rollout_buffer": rollout_buffer, "n_steps": n_rollout_steps})
        callback.on_rollout_end()
        return True

    def _act(self, env: VecEnv, obs: np.ndarray) -> tuple[np.ndarray, np.ndarray, th.Tensor, th.Tensor]:
        """Draw the actions for ``obs``, hand them to the workers, then (while they step) finish
        the values: the lean forward pass in its two halves."""
        policy = self.policy
        assert isinstance(policy, CTDEPolicy)
        with th.no_grad():
            actions, log_probs, pending = policy.rollout_actions(cast(th.Tensor, obs_as_tensor(obs, self.device)))
            actions_np = actions.cpu().numpy()
            env.step_async(actions_np)
            return obs, actions_np, policy.rollout_values(pending), log_probs

    def _file(self, callback: BaseCallback, rollout_buffer: RolloutBuffer, sent: tuple, new_obs: np.ndarray,
              rewards: np.ndarray, dones: np.ndarray, infos: list[dict[str, Any]], n_steps: int) -> bool:
        """A step's bookkeeping, as SB3's loop does it: the callback (False: stop), the info
        buffer, each horizon-stopped car's bootstrapped value, the rollout buffer."""
        obs, actions, values, log_probs = sent
        callback.update_locals({"new_obs": new_obs, "rewards": rewards, "dones": dones, "infos": infos,
                                "actions": actions, "values": values, "log_probs": log_probs,
                                "n_steps": n_steps, "rollout_buffer": rollout_buffer})
        if not callback.on_step():
            return False
        self._update_info_buffer(infos, dones)
        for slot in np.flatnonzero(dones):
            info = infos[slot]
            if info.get("terminal_observation") is not None and info.get("TimeLimit.truncated", False):
                terminal = self.policy.obs_to_tensor(info["terminal_observation"])[0]
                with th.no_grad():
                    terminal_value = self.policy.predict_values(terminal)[0]  # type: ignore[arg-type]
                rewards[slot] += self.gamma * terminal_value
        rollout_buffer.add(obs, actions.reshape(-1, 1), rewards, self._last_episode_starts,  # type: ignore[arg-type]
                           values, log_probs)
        self._last_obs = new_obs  # type: ignore[assignment]
        self._last_episode_starts = dones
        return True
