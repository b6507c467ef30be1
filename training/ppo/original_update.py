"""The paper's own update rules, on SB3's PPO through its extension points (nothing forked).

The paper's trainer (sdriving 0.1.0, ``agents/ppo_distributed/ppo.py``, ``update``) differs from
SB3's PPO update in two rules that :class:`~training.trainers.trainer.TrainConfig` can switch on:

* **KL stop of the actor only** (``kl_stop="actor"``): once the approximate KL of a minibatch
  (``mean(old log-prob - new log-prob)``) exceeds ``1.5 x target_kl``, the actor takes no more
  steps in that update, from that minibatch on, while the critic keeps training. SB3's rule
  (``"update"``) ends the whole update. Here SB3's own rule is off (``target_kl=None``); the
  rollout buffer hands each minibatch's old log-probabilities to the policy
  (:meth:`KLWatch.minibatch`), the policy's ``evaluate_actions`` measures the KL before the
  optimiser step (:meth:`KLWatch.measure`), and :class:`ActorStopAdam` leaves the actor's
  parameters alone once it is exceeded. Actor and critic have separate parameters (their own
  encoders), so one Adam over both steps each parameter exactly as the original's two Adams do.
* **Advantages normalised per car** (``advantage_normalisation="per_car"``): over the whole
  update, per car index (slot ``i`` of every instance), live transitions only, instead of SB3's
  per minibatch. The original's normalisation also reads its buffer's padded slots, which hold
  stale rows of earlier epochs; that is not copied.
"""

from __future__ import annotations

from typing import Iterable, Optional

import numpy as np
import torch as th


class KLWatch:
    """Shared between the rollout buffer, the policy and the optimiser of one model: whether the
    actor has stopped in the current update.

    Attributes:
        limit: the KL above which the actor stops (1.5 x the target KL).
        stopped: the actor takes no more steps in this update.
        stopped_at: the minibatch of this update at which it stopped (-1: not stopped).
    """

    def __init__(self, target_kl: float) -> None:
        self.limit = 1.5 * target_kl
        self.stopped = False
        self.stopped_at = -1
        self._old_log_prob: Optional[th.Tensor] = None
        self._minibatch = -1

    def start_update(self) -> None:
        """A new update: the actor may step again."""
        self.stopped, self.stopped_at, self._minibatch = False, -1, -1

    def minibatch(self, old_log_prob: th.Tensor) -> None:
        """The next minibatch's log-probabilities under the rollout's policy."""
        self._old_log_prob = old_log_prob
        self._minibatch += 1

    def measure(self, log_prob: th.Tensor) -> None:
        """The new log-probabilities of the minibatch the buffer handed over last: stop the actor
        when their approximate KL exceeds the limit."""
        if self._old_log_prob is None or self.stopped or log_prob.shape != self._old_log_prob.shape:
            return
        with th.no_grad():
            kl = float((self._old_log_prob - log_prob).mean())
        if kl > self.limit:
            self.stopped, self.stopped_at = True, self._minibatch
        self._old_log_prob = None


class ActorStopAdam(th.optim.Adam):
    """Adam that skips the actor's parameters once its :class:`KLWatch` says the actor stopped
    (their gradients are set aside for the step, so Adam leaves their values and moments alone)."""

    def __init__(self, params: Iterable, *args, **kwargs) -> None:
        super().__init__(params, *args, **kwargs)
        self.watch: Optional[KLWatch] = None
        self.actor_params: list[th.nn.Parameter] = []

    def step(self, closure=None):  # type: ignore[override]
        if self.watch is None or not self.watch.stopped:
            return super().step(closure)
        saved = [p.grad for p in self.actor_params]
        for p in self.actor_params:
            p.grad = None
        try:
            return super().step(closure)
        finally:
            for p, g in zip(self.actor_params, saved):
                p.grad = g


def normalise_per_car(advantages: np.ndarray, live: np.ndarray, n_cars: int) -> np.ndarray:
    """``advantages`` ``(T, S)`` (steps x slots, slot ``k * n_cars + i`` is car ``i`` of instance
    ``k``) with each car index's live entries shifted to mean 0 and scaled to standard deviation 1
    (population, plus 1e-7, as the original); padding entries are left as they are."""
    out = advantages.copy()
    steps, slots = advantages.shape
    car = np.arange(slots) % n_cars
    for i in range(n_cars):
        cols = car == i
        values = advantages[:, cols][live[:, cols]]
        if len(values) == 0:
            continue
        block = out[:, cols]
        mask = live[:, cols]
        block[mask] = (block[mask] - values.mean()) / (values.std() + 1e-7)
        out[:, cols] = block
    return out
