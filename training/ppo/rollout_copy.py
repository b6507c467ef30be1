"""A rollout's forward pass on another device than the update's (``--rollout-device cpu``).

A GPU pays for PPO's update (minibatches of thousands of rows) but not always for a rollout step's
forward pass over a few dozen rows, where kernel launches and host-device synchronisation rather
than arithmetic set the time: at the paper's 16 instances of 4 cars, the per-step forward cost
more on a lent H200 than on its CPU (docs/benchmarks.md). :class:`RolloutCopy` keeps a copy of the
policy's networks on the rollout device, refreshed whenever a weight changed since it was last
copied (the parameters' version counters: an optimiser step or a ``load_state_dict`` bumps them),
so SB3's loops stay as they are: the policy and its optimiser live on the update device, and only
a rollout step's forward pass (policy in evaluation mode, gradients off, as SB3's
``collect_rollouts`` calls it) runs on the copy.
"""

from __future__ import annotations

from typing import Any, Optional

import torch as th
from torch import nn


class RolloutCopy:
    """A copy on ``device`` of an SB3 policy's networks, a fresh policy of the same kind built from
    its constructor parameters on first use and refreshed from its weights whenever they changed."""

    def __init__(self, device: str | th.device) -> None:
        self.device = th.device(device)
        self._copy: Optional[nn.Module] = None
        self._key: Optional[tuple] = None
        self.refreshes = 0  # how many times the weights were copied (tests, benchmarks)

    @staticmethod
    def _weights_key(policy: nn.Module) -> tuple:
        # the same tensors (identity, storage) at the same versions: nothing has changed them
        return tuple((id(t), t.data_ptr(), t._version)
                     for t in (*policy.parameters(), *policy.buffers()))

    def of(self, policy: nn.Module) -> nn.Module:
        """The copy, with ``policy``'s current weights."""
        key = self._weights_key(policy)
        if self._copy is None:
            with th.random.fork_rng(devices=[]):  # its throw-away initial weights draw no numbers
                fresh = type(policy)(**policy._get_constructor_parameters())  # from the run's random stream
                self._copy = fresh.to(self.device)
            self._copy.set_training_mode(False)
            self._copy.requires_grad_(False)
        if key != self._key:
            with th.no_grad():
                self._copy.load_state_dict(policy.state_dict())
            self._key = key
            self.refreshes += 1
        return self._copy

    def forward(self, policy: nn.Module, obs: th.Tensor, deterministic: bool) -> tuple[Any, ...]:
        """``policy(obs, deterministic)`` computed on the copy, the results on ``policy``'s device."""
        out = self.of(policy)(obs.to(self.device), deterministic)
        return tuple(t.to(policy.device) for t in out)
