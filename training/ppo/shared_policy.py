"""The spline sub-policy as a greedy picker that env worker processes can call.

In bilevel training every acceleration-stage episode starts by asking the spline policy for each
car's path (``env.spline_policy``). With ``--num-cpus > 0`` those resets happen in worker
processes, which cannot call the learner's live SB3 policy. :class:`SharedSplinePicker` keeps the
policy's actor weights in one block of shared memory: the learner copies the weights in after
every spline update (never while a rollout is stepping the envs), and every process, the learner
included, evaluates the same numpy forward pass on it. The same picker is used with and without
workers, so the paths, and hence the rollouts, do not depend on the number of workers.
"""

from __future__ import annotations

import multiprocessing as mp
from typing import Any

import numpy as np
from gymnasium import spaces

from box2d_driving.policies.numpy_actor import greedy_from_layers


class SharedSplinePicker:
    """Greedy actions of an SB3 ``MlpPolicy`` (tanh hidden layers) from weights in shared memory.

    Args:
        observation_space: the scenario's stage-0 observation space (a flat ``Box``).
        action_space: its stage-0 action space (``Discrete``, ``MultiDiscrete`` or ``Box``).
        hidden: hidden layer sizes of the policy network.

    Greedy means what SB3's ``predict(deterministic=True)`` returns: the most likely category of
    each discrete component, or the Gaussian mean clipped to the ``Box`` bounds.
    """

    def __init__(self, observation_space: spaces.Box, action_space: spaces.Space, hidden: tuple[int, ...]):
        if isinstance(action_space, spaces.Discrete):
            out = int(action_space.n)
        elif isinstance(action_space, spaces.MultiDiscrete):
            out = int(sum(int(n) for n in action_space.nvec))
        elif isinstance(action_space, spaces.Box):
            out = int(np.prod(action_space.shape))
        else:
            raise TypeError(f"unsupported spline action space {action_space}")
        self.action_space = action_space
        sizes = [int(np.prod(observation_space.shape)), *map(int, hidden), out]
        self._shapes = [((o, i), (o,)) for i, o in zip(sizes[:-1], sizes[1:])]
        n = sum(o * i + o for (o, i), _ in self._shapes)
        # lock-free: the learner writes only between rollouts, when no worker reads
        self._buffer = mp.RawArray("f", n)

    def _layers(self) -> list[tuple[np.ndarray, np.ndarray]]:
        flat = np.frombuffer(self._buffer, dtype=np.float32)
        layers, at = [], 0
        for (o, i), _ in self._shapes:
            w = flat[at:at + o * i].reshape(o, i)
            b = flat[at + o * i:at + o * i + o]
            layers.append((w, b))
            at += o * i + o
        return layers

    def load(self, policy: Any) -> None:
        """Copy the actor weights of an SB3 ``ActorCriticPolicy`` (its ``mlp_extractor.policy_net``
        linear layers, then ``action_net``) into the shared block."""
        import torch as th

        linears = [m for m in policy.mlp_extractor.policy_net if isinstance(m, th.nn.Linear)]
        linears.append(policy.action_net)
        if len(linears) != len(self._shapes):
            raise ValueError(f"the policy has {len(linears)} linear layers, the picker {len(self._shapes)}")
        for (w, b), layer in zip(self._layers(), linears):
            weight = layer.weight.detach().cpu().numpy()
            if weight.shape != w.shape:
                raise ValueError(f"layer shape {weight.shape} does not match the picker's {w.shape}")
            w[...] = weight
            b[...] = layer.bias.detach().cpu().numpy()

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        """Greedy stage-0 actions for ``(N, D0)`` observations (the same forward pass as a shipped
        bilevel policy's spline actor, :func:`box2d_driving.policies.numpy_actor.greedy_from_layers`)."""
        return greedy_from_layers(self._layers(), self.action_space, obs)
