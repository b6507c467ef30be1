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

The paper's own code (sdriving 0.1.0) encodes differently: :class:`OriginalLidarEncoder`, two
*linear* strided convolutions to one channel (``lidar_encoder="original"``, the ``paper``
preset's). Ours ends in a ReLU on a single channel, which can die: every output zero for every
observation, no gradient ever again, an actor blind to its LiDAR (seen in most of the preset's
first runs: docs/paper_world.md). A linear encoder cannot.
"""

from __future__ import annotations

from contextlib import contextmanager
from typing import Any, Callable, Iterator, Sequence, cast

import torch as th
import torch.nn.functional as F
from torch import nn

from box2d_driving.policies.numpy_actor import (CHANNELS, KERNEL, ORIGINAL_KERNEL, ORIGINAL_PADDING,
                                                ORIGINAL_STRIDE, POOLED)

# the LiDAR encoders an actor and critic may have: ours (ReLU, 8 channels) and the paper code's
ENCODERS = ("relu", "original")
# the encoder of runs, sweeps and shipped policies from before ``lidar_encoder`` was recorded
# (ours was the only one, then the default, until 2026-12-06)
LEGACY_LIDAR_ENCODER = "relu"


class CircularConv1d(nn.Conv1d):
    """1-D convolution with wrap-around padding (the LiDAR is a ring). The reference
    implementation (:meth:`LidarEncoder.reference`); :func:`encode` computes the same faster."""

    bias: th.Tensor  # always made with a bias (nn.Conv1d's default), which encode reads

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
        self.out_dim: int = pooled + history * n_satnav

    # the layers by name (``nn.Sequential``'s ``[i]`` walks its modules: microseconds per access,
    # and a rollout's forward pass reads each layer every decision)
    @property
    def layer1(self) -> CircularConv1d:
        return cast(CircularConv1d, self.conv._modules["0"])

    @property
    def layer2(self) -> CircularConv1d:
        return cast(CircularConv1d, self.conv._modules["2"])

    @property
    def pooled(self) -> int:
        return cast(int, cast(nn.AdaptiveAvgPool1d, self.conv._modules["4"]).output_size)

    def forward(self, obs: th.Tensor) -> th.Tensor:
        return encode([self], obs)[0]

    def reference(self, obs: th.Tensor) -> th.Tensor:
        """The same output through ``nn.Conv1d`` (slow on the CPU; the tests' reference)."""
        n_lidar = self.history * self.n_rays
        lidar = obs[:, :n_lidar].reshape(-1, self.history, self.n_rays)
        return th.cat([self.conv(lidar).flatten(1), obs[:, n_lidar:]], dim=1)


class OriginalLidarEncoder(nn.Module):
    """The LiDAR encoder of the paper's own code (sdriving 0.1.0: ``PPOLidarCategoricalActor``'s
    ``lidar_features``, and its critics'): ``Conv1d(H, 1, 4, stride 2, padding 2, circular)``, then
    ``Conv1d(1, 1, 4, 2, 2, circular)``, no activation, average-pooled to 25 features (100 rays ->
    51 -> 26 -> 25), concatenated with the sat-nav history as :class:`LidarEncoder` does. Weights
    orthogonal and biases zero, as its ``init_weights``.

    Linear throughout, so on many rows it runs as one ``(H * n_rays, 25)`` matrix built from the
    two kernels (the encoder applied to the unit vectors; gradients reach the kernels through it):
    one product instead of two strided convolutions, whose CPU weight gradient is slow."""

    def __init__(self, history: int, n_rays: int, n_satnav: int, pooled: int = POOLED) -> None:
        super().__init__()
        self.history, self.n_rays = history, n_rays
        k, s, p = ORIGINAL_KERNEL, ORIGINAL_STRIDE, ORIGINAL_PADDING
        self.conv = nn.Sequential(
            nn.Conv1d(history, 1, k, s, p, padding_mode="circular"),
            nn.Conv1d(1, 1, k, s, p, padding_mode="circular"),
            nn.AdaptiveAvgPool1d(pooled),
        )
        for layer in (self.layer1, self.layer2):
            nn.init.orthogonal_(layer.weight)
            nn.init.zeros_(cast(th.Tensor, layer.bias))
        self.out_dim: int = pooled + history * n_satnav

    @property
    def layer1(self) -> nn.Conv1d:
        return cast(nn.Conv1d, self.conv._modules["0"])

    @property
    def layer2(self) -> nn.Conv1d:
        return cast(nn.Conv1d, self.conv._modules["1"])

    @property
    def pooled(self) -> int:
        return cast(int, cast(nn.AdaptiveAvgPool1d, self.conv._modules["2"]).output_size)

    def forward(self, obs: th.Tensor) -> th.Tensor:
        if not th.is_grad_enabled():  # a rollout, an evaluation: the product kept from the weights
            return _encode_original_no_grad([self], obs)[0]
        n = self.history * self.n_rays
        if obs.shape[0] <= n:  # few rows with gradients: the convolutions themselves
            return self.reference(obs)
        matrix, offset = self.as_matrix()
        return th.cat([th.addmm(offset, obs[:, :n], matrix), obs[:, n:]], dim=1)

    def as_matrix(self) -> tuple[th.Tensor, th.Tensor]:
        """``(matrix, offset)``: the encoder as one affine map of the flat LiDAR history,
        ``features = lidar @ matrix + offset`` with ``matrix`` ``(H * n_rays, 25)`` (what each LiDAR
        column adds: the encoder applied to the unit vectors) and ``offset`` ``(1, 25)`` (the
        biases' part); gradients reach the kernels through both."""
        n = self.history * self.n_rays
        weight = self.layer1.weight
        basis = th.eye(n, dtype=weight.dtype, device=weight.device).reshape(n, self.history, self.n_rays)
        matrix = self._weights_only(basis).flatten(1)
        offset = self.conv(weight.new_zeros(1, self.history, self.n_rays)).flatten(1)
        return matrix, offset

    def _weights_only(self, x: th.Tensor) -> th.Tensor:
        """The encoder without its biases (their part is added once, not cancelled out of every
        unit vector's: that would cost the biases' gradients float precision)."""
        for layer in (self.layer1, self.layer2):
            p = cast(int, layer.padding[0])
            x = F.conv1d(F.pad(x, (p, p), mode="circular"), layer.weight, None, layer.stride)
        return F.adaptive_avg_pool1d(x, self.pooled)

    def reference(self, obs: th.Tensor) -> th.Tensor:
        """The same output through ``nn.Conv1d`` (the tests' reference)."""
        n = self.history * self.n_rays
        lidar = obs[:, :n].reshape(-1, self.history, self.n_rays)
        return th.cat([self.conv(lidar).flatten(1), obs[:, n:]], dim=1)


# pooled LiDAR features that vary less than this over a policy's own observations (the LiDAR
# values span 0-10): the encoder passes nothing of what the car sees, the actor is blind
BLIND_SPREAD = 1e-4


def lidar_spread(encoder: "LidarEncoder | OriginalLidarEncoder", obs: th.Tensor) -> tuple[float, float]:
    """``(inputs, features)``: the largest standard deviation across the rows of ``obs`` (flat
    observations, LiDAR history first) of its LiDAR columns, and of ``encoder``'s pooled LiDAR
    features. Features that stay below :data:`BLIND_SPREAD` while the inputs vary: a dead encoder."""
    if obs.shape[0] < 2:
        return 0.0, 0.0
    with th.no_grad():
        lidar = obs[:, : encoder.history * encoder.n_rays]
        features = encoder(obs)[:, : encoder.pooled]
        return float(lidar.std(0).max()), float(features.std(0).max())


def make_encoder(kind: str, history: int, n_rays: int, n_satnav: int) -> "LidarEncoder | OriginalLidarEncoder":
    """A LiDAR encoder of the kind named in :data:`ENCODERS` (``ValueError`` otherwise)."""
    if kind == "relu":
        return LidarEncoder(history, n_rays, n_satnav)
    if kind == "original":
        return OriginalLidarEncoder(history, n_rays, n_satnav)
    raise ValueError(f"lidar_encoder must be one of {ENCODERS}, got {kind!r}")


def block_size(n_rays: int) -> int:
    """Rays per layer-1 block: the largest of 5, 4, 2, 1 dividing ``n_rays`` (5 measured fastest
    for 100 rays on a 2-core CPU: fewer, wider products than 1-2, less zero padding than 10)."""
    return next(p for p in (5, 4, 2, 1) if n_rays % p == 0)


_INDEX_CACHE: dict[tuple[object, ...], th.Tensor] = {}


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
_STAND_IN = False  # see encoders_cost_nothing
# Without gradients, up to this many rows go the way of :func:`_encode_no_grad` (fewer, fused
# operations: a rollout step's few dozen rows); more rows are faster the training way, whose
# layer-2 products are a quarter of the fused block diagonal's
FUSED_ROWS = 1024


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


@contextmanager
def encoders_cost_nothing() -> Iterator[None]:
    """Within this block :func:`encode` returns stand-ins that cost next to nothing: each encoder's
    output shape filled from the first observation columns times its layer-2 bias (so gradients
    still reach the layers after it). Not a model: ``bench --train`` times an update this way to
    bound what any faster encoder could give."""
    global _STAND_IN
    before, _STAND_IN = _STAND_IN, True
    try:
        yield
    finally:
        _STAND_IN = before



def encode(encoders: Sequence[Any], obs: th.Tensor) -> list[th.Tensor]:
    """The outputs of ``encoders`` (same architecture, own weights) on the same rows ``obs``."""
    if _REFERENCE:
        return [enc.reference(obs) for enc in encoders]
    if _STAND_IN:
        return [obs[:, :enc.out_dim] * enc.layer2.bias for enc in encoders]
    if not isinstance(encoders[0], LidarEncoder):  # the paper code's linear encoders: each its own product
        if not th.is_grad_enabled():
            return _encode_original_no_grad(encoders, obs)
        return [enc(obs) for enc in encoders]
    if obs.shape[0] <= FUSED_ROWS and not th.is_grad_enabled():
        return _encode_no_grad(encoders, obs)
    first = encoders[0]
    h, r = first.history, first.n_rays
    conv1s = [enc.layer1 for enc in encoders]
    conv2s = [enc.layer2 for enc in encoders]
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
        out = cast(th.Tensor, sum(th.roll(tap, pad - k, dims=1) for k, tap in enumerate(taps.unbind(-1))))
        outs.append(out + conv2.bias)
    out = th.stack(outs, dim=1).relu_()  # (B, E, R)
    pooled = F.adaptive_avg_pool1d(out, first.pooled)  # (B, E, 25)
    rest = obs[:, h * r: first.out_dim - pooled.shape[2] + h * r]
    return [th.cat([pooled[:, i], rest], dim=1) for i in range(len(encoders))]


def _fused_weights(encoders: Sequence[LidarEncoder], device: th.device) -> tuple[th.Tensor, ...]:
    """Every encoder's layer-1 block matrix side by side ``(in_ch * span, E * P * out_ch)`` with its
    biases, the layer-2 tap matrices on one block diagonal ``(E * P * out_ch, E * P * kernel)`` and
    the layer-2 biases ``(E,)``: built from the weights once and kept on the first encoder until
    an optimiser step changes a weight (its version counter) or the weights are replaced."""
    return _kept(encoders, "_fused", lambda: _build_fused_weights(encoders, device))


def _kept(encoders: Sequence[Any], slot: str, build: Callable[[], tuple[th.Tensor, ...]]) -> tuple[th.Tensor, ...]:
    """``build()``'s tensors, kept on the first encoder under ``slot`` (not a module attribute: no
    state) and built again only once an optimiser step changes one of the encoders' weights (its
    version counter) or the weights are replaced."""
    params = [cast(th.Tensor, p) for enc in encoders for layer in (enc.layer1, enc.layer2)
              for p in (layer.weight, layer.bias)]
    key = [p._version for p in params]
    cached = encoders[0].__dict__.get(slot)
    if cached is not None and cached[0] == key and all(a is b for a, b in zip(cached[1], params)):
        return cast(tuple[th.Tensor, ...], cached[2])
    weights = build()
    encoders[0].__dict__[slot] = (key, params, weights)
    return weights


def _build_fused_weights(encoders: Sequence[LidarEncoder], device: th.device) -> tuple[th.Tensor, ...]:
    conv1 = encoders[0].layer1
    out_ch, kernel = conv1.out_channels, conv1.kernel_size[0]
    block = block_size(encoders[0].n_rays)
    index = _toeplitz_index(out_ch, conv1.in_channels, kernel, block).to(device)
    m1 = th.cat([th.cat([enc.layer1.weight.reshape(-1), enc.layer1.weight.new_zeros(1)])[index]
                 for enc in encoders], dim=1)
    b1 = th.cat([enc.layer1.bias.repeat(block) for enc in encoders])
    m2 = th.block_diag(*[enc.layer2.weight[0] for enc in encoders for _ in range(block)])
    b2 = th.cat([enc.layer2.bias for enc in encoders])
    return m1, b1, m2, b2


def _encode_no_grad(encoders: Sequence[LidarEncoder], obs: th.Tensor) -> list[th.Tensor]:
    """:func:`encode` without gradients (a rollout's forward pass on a few dozen rows, where the
    number of operations, not their size, sets the time): every encoder in the same two products,
    with matrices built once per weight update (:func:`_fused_weights`), and layer 2's ring sum
    over all encoders at once; within float rounding of the training path."""
    first = encoders[0]
    h, r, e = first.history, first.n_rays, len(encoders)
    conv1 = first.layer1
    kernel = conv1.kernel_size[0]
    pad, block = kernel // 2, block_size(r)
    b = obs.shape[0]
    m1, b1, m2, b2 = _fused_weights(encoders, obs.device)
    cols = obs.index_select(1, _window_index(h, r, kernel, block).to(obs.device)).reshape(b * (r // block), -1)
    hidden = th.addmm(b1, cols, m1).relu_()  # (B R / P, E P out_ch)
    taps = (hidden @ m2).reshape(b, r // block, e, block * kernel).transpose(1, 2).reshape(b, e, r, kernel)
    out = sum(th.roll(tap, pad - k, dims=2) for k, tap in enumerate(taps.unbind(-1)))
    out = (out + b2[:, None]).relu_()  # (B, E, R)
    pooled = F.adaptive_avg_pool1d(out, first.pooled)  # (B, E, 25)
    rest = obs[:, h * r: first.out_dim - pooled.shape[2] + h * r]
    return [th.cat([pooled[:, i], rest], dim=1) for i in range(e)]


def _original_fused(encoders: Sequence[OriginalLidarEncoder]) -> tuple[th.Tensor, th.Tensor]:
    """Every paper-code encoder's :meth:`~OriginalLidarEncoder.as_matrix` side by side,
    ``(H * n_rays, E * 25)`` and ``(1, E * 25)``, kept until the weights change (:func:`_kept`, as
    :func:`_fused_weights` keeps ours)."""
    def build() -> tuple[th.Tensor, ...]:
        with th.no_grad():
            parts = [enc.as_matrix() for enc in encoders]
            return th.cat([m for m, _ in parts], dim=1), th.cat([o for _, o in parts], dim=1)
    matrix, offset = _kept(encoders, "_fused_original", build)
    return matrix, offset


def _encode_original_no_grad(encoders: Sequence[OriginalLidarEncoder], obs: th.Tensor) -> list[th.Tensor]:
    """:func:`encode` of the paper code's encoders without gradients (a rollout step's few dozen
    rows, where the count of operations sets the time: two padded strided convolutions per encoder
    cost about 1 ms a step on a 2-core CPU): one product of the rows with every encoder's kept
    matrix; within float rounding of the convolutions."""
    first = encoders[0]
    n, pooled = first.history * first.n_rays, first.pooled
    matrix, offset = _original_fused(encoders)
    features = th.addmm(offset, obs[:, :n], matrix)  # (B, E * 25)
    rest = obs[:, n:]
    return [th.cat([features[:, i * pooled:(i + 1) * pooled], rest], dim=1) for i in range(len(encoders))]

