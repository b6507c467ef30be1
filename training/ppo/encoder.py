"""The LiDAR encoder of the actor and the critic, and a fast way to run several of them at once.

Architecture (the paper's): the LiDAR history ``(H, n_rays)`` goes through two circular 1-D
convolutions (``H -> 8`` channels, then ``8 -> 1``, kernel 5, ReLU after each), is average-pooled
to 25 features and concatenated with the sat-nav history. The weights live in ordinary
``nn.Conv1d`` modules (``conv.0`` and ``conv.2``), so checkpoints keep their names.

How it is computed: PyTorch's CPU convolution is slow for these shapes (5 input channels, length
100, thousands of rows; its weight gradient especially), and the two encoders of the actor and
the critic read the same rows during a PPO update. :func:`encode` therefore runs any number of
encoders on the same rows as matrix products:

* the rows: rays are cut into blocks of ``P`` neighbours; one row holds the ``P + 4`` rays (all
  ``H`` frames) a block's outputs read, gathered from the observation columns in one
  ``index_select`` (shared by every encoder);
* layer 1 as a block-Toeplitz product of those rows with a matrix built from one encoder's
  kernels (``P x 8`` columns);
* layer 2 (``8 -> 1``, kernel 5) as one product of that encoder's hidden units to 5 kernel taps
  per ray (on the same blocks of ``P`` rays, so the product is ``P`` times wider) followed by the
  sum of the ring-shifted taps.

The result equals the convolution (same sums, other order: within float rounding), which
``tests/test_training.py`` checks with gradients.
"""

from __future__ import annotations

from contextlib import contextmanager
from typing import Iterator, Sequence

import torch as th
import torch.nn.functional as F
from torch import nn

CHANNELS, KERNEL, POOLED = 8, 5, 25


class CircularConv1d(nn.Conv1d):
    """1-D convolution with wrap-around padding (the LiDAR is a ring). The reference
    implementation (:meth:`LidarEncoder.reference`); :func:`encode` computes the same faster."""

    def __init__(self, in_channels: int, out_channels: int, kernel: int) -> None:
        super().__init__(in_channels, out_channels, kernel)
        self.pad = kernel // 2

    def forward(self, x: th.Tensor) -> th.Tensor:
        p = self.pad
        if p:
            x = th.cat([x[..., -p:], x, x[..., :p]], dim=-1)
        return super().forward(x)


class LidarEncoder(nn.Module):
    """Circular conv encoder of the LiDAR history, concatenated with the sat-nav history.
    Input: flat observations ``(B, H * n_rays + H * n_satnav)``; output ``(B, out_dim)`` with
    ``out_dim = 25 + H * n_satnav``."""

    def __init__(self, history: int, n_rays: int, n_satnav: int, channels: int = CHANNELS,
                 kernel: int = KERNEL, pooled: int = POOLED) -> None:
        super().__init__()
        self.history, self.n_rays = history, n_rays
        self.conv = nn.Sequential(
            CircularConv1d(history, channels, kernel), nn.ReLU(),
            CircularConv1d(channels, 1, kernel), nn.ReLU(),
            nn.AdaptiveAvgPool1d(pooled),
        )
        self.out_dim = pooled + history * n_satnav

    def forward(self, obs: th.Tensor) -> th.Tensor:
        return encode([self], obs)[0]

    def reference(self, obs: th.Tensor) -> th.Tensor:
        """The same output through ``nn.Conv1d`` (slow on the CPU; the tests' reference)."""
        n_lidar = self.history * self.n_rays
        lidar = obs[:, :n_lidar].reshape(-1, self.history, self.n_rays)
        return th.cat([self.conv(lidar).flatten(1), obs[:, n_lidar:]], dim=1)


def block_size(n_rays: int) -> int:
    """Rays per layer-1 block: the largest of 5, 4, 2, 1 dividing ``n_rays`` (5 measured fastest
    for 100 rays on a 2-core CPU: fewer, wider products than 1-2, less zero padding than 10)."""
    return next(p for p in (5, 4, 2, 1) if n_rays % p == 0)


_INDEX_CACHE: dict[tuple[int, ...], th.Tensor] = {}


def _toeplitz_index(out_ch: int, in_ch: int, kernel: int, block: int) -> th.Tensor:
    """Where each entry of an encoder's layer-1 block matrix ``(in_ch * (block + kernel - 1),
    block * out_ch)`` comes from in its flattened ``(out_ch, in_ch, kernel)`` weights; the index
    one past their end (a zero appended to them) where the kernel does not reach."""
    key = ("toeplitz", out_ch, in_ch, kernel, block)
    if key not in _INDEX_CACHE:
        span = block + kernel - 1
        c = th.arange(in_ch)[:, None, None, None]
        j = th.arange(span)[None, :, None, None]
        q = th.arange(block)[None, None, :, None]
        o = th.arange(out_ch)[None, None, None, :]
        k = j - q  # tap of the kernel that input ray j feeds into output ray q of a block
        flat = (o * in_ch + c) * kernel + k
        zero = out_ch * in_ch * kernel
        _INDEX_CACHE[key] = th.where((k >= 0) & (k < kernel), flat, zero).reshape(in_ch * span, -1)
    return _INDEX_CACHE[key]


def _window_index(history: int, n_rays: int, kernel: int, block: int) -> th.Tensor:
    """Observation columns of the layer-1 rows: for block ``m`` of ``block`` rays, frame ``h``
    and window place ``j``, the LiDAR column ``h * n_rays + (m * block + j - pad) mod n_rays`` (the
    ring's wrap-around padding), so one ``index_select`` gathers every row's window at once."""
    key = ("window", history, n_rays, kernel, block)
    if key not in _INDEX_CACHE:
        pad, span = kernel // 2, block + kernel - 1
        m = th.arange(n_rays // block)[:, None, None]
        h = th.arange(history)[None, :, None]
        j = th.arange(span)[None, None, :]
        _INDEX_CACHE[key] = (h * n_rays + (m * block + j - pad) % n_rays).reshape(-1)
    return _INDEX_CACHE[key]


_REFERENCE = False


@contextmanager
def reference_convolutions() -> Iterator[None]:
    """Within this block :func:`encode` runs the ``nn.Conv1d`` reference instead: what counts
    the model's nominal operations (``bench --train``), not the zeros the fast way multiplies."""
    global _REFERENCE
    before, _REFERENCE = _REFERENCE, True
    try:
        yield
    finally:
        _REFERENCE = before


def encode(encoders: Sequence[LidarEncoder], obs: th.Tensor) -> list[th.Tensor]:
    """The outputs of ``encoders`` (same architecture, own weights) on the same rows ``obs``."""
    if _REFERENCE:
        return [enc.reference(obs) for enc in encoders]
    first = encoders[0]
    h, r = first.history, first.n_rays
    conv1s = [enc.conv[0] for enc in encoders]
    conv2s = [enc.conv[2] for enc in encoders]
    out_ch, kernel = conv1s[0].out_channels, conv1s[0].kernel_size[0]
    pad, block = kernel // 2, block_size(r)
    b = obs.shape[0]
    # each row of ``cols``: one block of rays, the window (all frames) its outputs read; gathered
    # straight from the observation columns (no padded copy of the ring, no unfold copy)
    cols = obs.index_select(1, _window_index(h, r, kernel, block).to(obs.device))
    cols = cols.reshape(b * (r // block), -1)
    index = _toeplitz_index(out_ch, h, kernel, block).to(obs.device)
    outs = []
    for conv1, conv2 in zip(conv1s, conv2s):
        # each encoder's own two products on the shared rows (one product over all encoders'
        # columns would need slicing them apart again, whose gradient costs a zero-filled copy)
        m1 = th.cat([conv1.weight.reshape(-1), obs.new_zeros(1)])[index]
        hidden = th.addmm(conv1.bias.repeat(block), cols, m1).relu_()  # (B R / P, P x out_ch)
        # layer 2: one product per block of P rays (P copies of the (out_ch, kernel) taps on the
        # diagonal): wider than one per ray, whose (B x R, 8) x (8, 5) shape ran far below the
        # matmul speed
        taps = (hidden @ th.block_diag(*([conv2.weight[0]] * block))).reshape(b, r, kernel)
        # output ray p reads hidden ray p + k - pad with tap k: roll tap k by pad - k and sum
        # (unbind, not indexing: its gradient is one stack, not a zero-filled copy per tap)
        out = sum(th.roll(tap, pad - k, dims=1) for k, tap in enumerate(taps.unbind(-1)))
        outs.append(out + conv2.bias)
    out = th.stack(outs, dim=1).relu_()  # (B, E, R)
    pooled = F.adaptive_avg_pool1d(out, first.conv[4].output_size)  # (B, E, 25)
    rest = obs[:, h * r: first.out_dim - pooled.shape[2] + h * r]
    return [th.cat([pooled[:, i], rest], dim=1) for i in range(len(encoders))]
