"""The policy's forward pass during a rollout, in numpy: logits and values of one vector-env step.

A rollout step evaluates the actor and the centralised critic on a few dozen slot rows (every car
of every env instance), without gradients. At that size torch spends its time in the per-operation
overhead of some sixty small operations, not in arithmetic; numpy's per-operation cost is several
times lower. :meth:`training.ppo.policy.CTDEPolicy.forward` therefore computes the logits and
values of such a step here, from numpy views of the network's own CPU parameters (they share
memory, so every optimiser step is seen at once), and SB3's distribution samples the actions from
those logits as it always does.

The network is the one of :mod:`training.ppo.policy` (both LiDAR encoders as in
:func:`training.ppo.encoder._encode_no_grad`, the actor MLP, the critic's projection, masked mean
over the live cars of each instance and MLP, SB3's heads); the sums are the same in another order
(float32), so logits and values agree with the torch forward within float rounding
(``tests/test_training.py`` checks it for every critic variant).
"""

from __future__ import annotations

from typing import Optional

import numpy as np
import torch as th

from training.ppo.encoder import _fused_weights, _window_index, block_size


def _adaptive_average(length: int, size: int) -> np.ndarray:
    """``(length, size)``: ``nn.AdaptiveAvgPool1d(size)`` as a matrix (output ``i`` averages
    inputs ``floor(i L / size)`` up to ``ceil((i + 1) L / size)``)."""
    m = np.zeros((length, size), dtype=np.float32)
    for i in range(size):
        lo, hi = (i * length) // size, -(-(i + 1) * length // size)
        m[lo:hi, i] = 1.0 / (hi - lo)
    return m


class RolloutForward:
    """Logits and values of a policy (:class:`training.ppo.policy.CTDEPolicy`) for whole env
    instances of slot rows, in numpy. Derived matrices are rebuilt when a weight changes."""

    def __init__(self, policy) -> None:
        self.policy = policy
        net = policy.mlp_extractor
        enc = net.actor_encoder
        self.history, self.n_rays = enc.history, enc.n_rays
        kernel = enc.layer1.kernel_size[0]
        self.block = block_size(self.n_rays)
        self.window = _window_index(self.history, self.n_rays, kernel, self.block).numpy()
        pad = kernel // 2
        p, k = np.arange(self.n_rays)[:, None], np.arange(kernel)[None, :]
        self.taps = (((p + k - pad) % self.n_rays) * kernel + k).reshape(-1)  # ring sum as one gather
        self.kernel = kernel
        self.pool = _adaptive_average(self.n_rays, enc.pooled)
        self._key: Optional[list] = None

    def _weights(self) -> tuple:
        net = self.policy.mlp_extractor
        m1, b1, m2, b2 = _fused_weights([net.actor_encoder, net.critic_encoder], th.device("cpu"))
        key = [id(m1)] + [(p.data_ptr(), p._version) for p in self.policy.parameters()]
        if key != self._key:
            def lin(module) -> tuple[np.ndarray, np.ndarray]:
                return module.weight.detach().numpy().T, module.bias.detach().numpy()

            self._arrays = (m1.numpy(), b1.numpy(), m2.numpy(), b2.numpy(),
                            [lin(net.actor_mlp[0]), lin(net.actor_mlp[2])], lin(net.critic_proj[0]),
                            lin(net.critic_mlp[0]), lin(self.policy.action_net), lin(self.policy.value_net))
            self._key = key
        return self._arrays

    def __call__(self, own: np.ndarray, n_cars: int, alive: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(logits (B, A), values (B, 1))`` of own observations ``(B, D)``, ``B = K * n_cars`` rows
        of ``K`` instances in slot order, with each row's alive flag ``(B,)``."""
        m1, b1, m2, b2, actor, proj, critic, head, value = self._weights()
        h, r, blk, kernel = self.history, self.n_rays, self.block, self.kernel
        b = own.shape[0]
        cols = own[:, self.window].reshape(b * (r // blk), -1)
        hidden = np.maximum(cols @ m1 + b1, 0.0)  # (B R / P, 2 P out_ch)
        taps = (hidden @ m2).reshape(b, r // blk, 2, blk * kernel).transpose(0, 2, 1, 3).reshape(b, 2, r * kernel)
        rays = np.maximum(taps[:, :, self.taps].reshape(b, 2, r, kernel).sum(axis=-1) + b2[:, None], 0.0)
        pooled = rays @ self.pool  # (B, 2, 25)
        rest = own[:, h * r:]
        z = np.concatenate([pooled[:, 0], rest], axis=1)
        for w, bias in actor:
            z = np.tanh(z @ w + bias)
        logits = z @ head[0] + head[1]
        zc = np.tanh(np.concatenate([pooled[:, 1], rest], axis=1) @ proj[0] + proj[1])  # (B, 256)
        kind = self.policy.mlp_extractor.critic
        if kind == "own":
            latent = np.tanh(zc @ critic[0] + critic[1])
        else:
            teams = (zc * alive[:, None]).reshape(b // n_cars, n_cars, -1).sum(axis=1)
            mean = teams / np.maximum(alive.reshape(b // n_cars, n_cars).sum(axis=1), 1.0)[:, None]
            if kind == "mean":  # one value per team
                latent = np.repeat(np.tanh(mean @ critic[0] + critic[1]), n_cars, axis=0)
            else:  # own+mean
                both = np.concatenate([zc, np.repeat(mean, n_cars, axis=0)], axis=1)
                latent = np.tanh(both @ critic[0] + critic[1])
        values = latent @ value[0] + value[1]
        return logits.astype(np.float32, copy=False), values.astype(np.float32, copy=False)
