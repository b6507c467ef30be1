"""Trained actors evaluated with numpy alone: no torch, no SB3.

Two networks are run here, from the weights of a checkpoint (``state_dict`` names, as the trainer
writes them):

* :class:`DrivingActor`: the acceleration policy. The LiDAR history ``(H, n_rays)`` goes through
  two circular 1-D convolutions (``H -> 8`` channels, then ``8 -> 1``, kernel 5, ReLU after each),
  is average-pooled to 25 features and concatenated with the sat-nav history; then two tanh layers
  of 256 and the action logits (:meth:`DrivingActor.logits`; the greedy action is the largest).
  A policy trained with the paper code's encoder (``lidar_encoder="original"``: two linear
  convolutions ``H -> 1 -> 1`` channel, kernel 4, stride 2, no ReLU) is read from its layer names
  (``conv.0`` and ``conv.1``; ours are ``conv.0`` and ``conv.2``).
* :class:`MlpActor`: the spline (stage-0) policy of a bilevel run, an SB3 ``MlpPolicy`` actor:
  tanh hidden layers, then the action head. Greedy action: what SB3's
  ``predict(deterministic=True)`` returns (the most likely category of each discrete component,
  or the Gaussian mean clipped to a ``Box``'s bounds).

The sums are the same as the trainer's (float32), in another order, so logits agree within float
rounding; ``tests/test_numpy_actor.py`` checks equal actions on recorded observations of every
shipped policy.
"""

from __future__ import annotations

import math
from typing import Any, Mapping, Optional

import numpy as np
from gymnasium import spaces
from numpy.lib.stride_tricks import sliding_window_view

from box2d_driving.policies.checkpoint_file import CheckpointError

# The acceleration policy's architecture (the trainer's networks, training/ppo/, import these):
# LiDAR convolutions of CHANNELS channels and kernel KERNEL, POOLED features, HIDDEN tanh units
CHANNELS, KERNEL, POOLED, HIDDEN = 8, 5, 25, 256
# the paper code's encoder (``lidar_encoder="original"``): two linear convolutions to one channel,
# kernel 4, stride 2, wrap-around padding 2
ORIGINAL_KERNEL, ORIGINAL_STRIDE, ORIGINAL_PADDING = 4, 2, 2
# the state_dict prefixes of what acting reads: the CTDE actor's encoder and MLP, SB3's action
# head, and a bilevel spline stage's MLP actor (an actor-only checkpoint holds these alone)
ACTOR_PREFIXES = ("mlp_extractor.actor_", "mlp_extractor.policy_net.", "action_net.")


def is_actor_key(name: str) -> bool:
    """Whether the policy tensor ``name`` (a state_dict key) is read when acting."""
    return name.startswith(ACTOR_PREFIXES)

Layers = list[tuple[np.ndarray, np.ndarray]]  # (weight (out, in), bias (out,)) per linear layer


def _weight(weights: Mapping[str, np.ndarray], name: str) -> np.ndarray:
    if name not in weights:
        raise CheckpointError(f"the checkpoint has no {name!r}: not an actor of this kind")
    return np.ascontiguousarray(weights[name], dtype=np.float32)


def linear_layers(weights: Mapping[str, np.ndarray], names: list[str]) -> Layers:
    """``(weight, bias)`` of each named linear layer (``NAME.weight`` / ``NAME.bias``)."""
    return [(_weight(weights, f"{n}.weight"), _weight(weights, f"{n}.bias")) for n in names]


def circular_conv(x: np.ndarray, weight: np.ndarray, bias: np.ndarray) -> np.ndarray:
    """``(B, C_in, L)`` -> ``(B, C_out, L)``: a 1-D convolution (cross-correlation, as
    ``torch.nn.Conv1d``) over a ring, padded by wrapping ``kernel // 2`` values round each end."""
    return strided_circular_conv(x, weight, bias, 1, weight.shape[2] // 2)


def strided_circular_conv(x: np.ndarray, weight: np.ndarray, bias: np.ndarray, stride: int,
                          pad: int) -> np.ndarray:
    """``(B, C_in, L)`` -> ``(B, C_out, L_out)``: ``torch.nn.Conv1d(..., stride, pad,
    padding_mode="circular")``, ``L_out = (L + 2 pad - kernel) // stride + 1``."""
    out_ch, in_ch, kernel = weight.shape
    b, _, length = x.shape
    ring = np.concatenate([x[..., length - pad:], x, x[..., :pad]], axis=2)
    windows = sliding_window_view(ring, kernel, axis=2)[:, :, ::stride]  # (B, C_in, L_out, K)
    n = windows.shape[2]
    cols = windows.transpose(0, 2, 1, 3).reshape(b * n, in_ch * kernel)
    out = cols @ weight.reshape(out_ch, in_ch * kernel).T + bias
    return out.reshape(b, n, out_ch).transpose(0, 2, 1)


def adaptive_average(length: int, size: int) -> np.ndarray:
    """``(length, size)`` matrix of ``torch.nn.AdaptiveAvgPool1d(size)``: output ``i`` averages
    inputs ``floor(i L / size)`` up to ``ceil((i + 1) L / size)``."""
    m = np.zeros((length, size), dtype=np.float32)
    for i in range(size):
        lo, hi = (i * length) // size, math.ceil((i + 1) * length / size)
        m[lo:hi, i] = 1.0 / (hi - lo)
    return m


class DrivingActor:
    """The acceleration policy's actor (see the module docstring) from checkpoint weights.

    Args:
        weights: the checkpoint's policy arrays by ``state_dict`` name.
        history: frames in an observation (H).
        n_rays: LiDAR rays per frame.
        pooled: LiDAR features after pooling (25 in the paper's encoder).
    """

    def __init__(self, weights: Mapping[str, np.ndarray], history: int, n_rays: int,
                 pooled: int = 25, n_actions: Optional[int] = None) -> None:
        prefix = "mlp_extractor.actor_encoder.conv"
        # the paper code's linear encoder names its second convolution conv.1 (no ReLU between)
        self.original = f"{prefix}.1.weight" in weights
        second = 1 if self.original else 2
        self.conv1 = (_weight(weights, f"{prefix}.0.weight"), _weight(weights, f"{prefix}.0.bias"))
        self.conv2 = (_weight(weights, f"{prefix}.{second}.weight"), _weight(weights, f"{prefix}.{second}.bias"))
        self.mlp = linear_layers(weights, ["mlp_extractor.actor_mlp.0", "mlp_extractor.actor_mlp.2"])
        self.head = linear_layers(weights, ["action_net"])[0]
        self.history, self.n_rays = history, n_rays
        check_actor_shapes(self, history, n_rays, pooled, n_actions)
        self.pool = adaptive_average(self._encoded_rays(n_rays), pooled)
        self.obs_dim = history * n_rays + self.mlp[0][0].shape[1] - pooled

    def _encoded_rays(self, n_rays: int) -> int:
        """Values per observation the convolutions give before pooling (ours keep every ray; the
        paper code's halve them twice: 100 -> 51 -> 26)."""
        if not self.original:
            return n_rays
        for _ in range(2):
            n_rays = (n_rays + 2 * ORIGINAL_PADDING - ORIGINAL_KERNEL) // ORIGINAL_STRIDE + 1
        return n_rays

    def lidar_features(self, obs: np.ndarray) -> np.ndarray:
        """The pooled LiDAR features ``(B, 25)`` the actor's MLP reads for own observations ``(B, D)``."""
        x = np.asarray(obs, dtype=np.float32)
        if x.ndim != 2 or x.shape[1] != self.obs_dim:
            raise ValueError(f"observations must be (B, {self.obs_dim}), got {x.shape}: "
                             f"wrong env settings for this policy?")
        h, r = self.history, self.n_rays
        lidar = x[:, : h * r].reshape(len(x), h, r)
        if self.original:
            step = (ORIGINAL_STRIDE, ORIGINAL_PADDING)
            rays = strided_circular_conv(strided_circular_conv(lidar, *self.conv1, *step), *self.conv2, *step)[:, 0]
        else:
            hidden = np.maximum(circular_conv(lidar, *self.conv1), 0.0)
            rays = np.maximum(circular_conv(hidden, *self.conv2), 0.0)[:, 0]  # (B, R)
        return rays @ self.pool

    def logits(self, obs: np.ndarray) -> np.ndarray:
        """Action logits ``(B, n_actions)`` for own observations ``(B, D)``."""
        x = np.asarray(obs, dtype=np.float32)
        z = np.concatenate([self.lidar_features(x), x[:, self.history * self.n_rays:]], axis=1)
        for w, b in self.mlp:
            z = np.tanh(z @ w.T + b)
        w, b = self.head
        return z @ w.T + b


def check_actor_shapes(actor: "DrivingActor", history: int, n_rays: int, pooled: int,
                       n_actions: Optional[int]) -> None:
    """Every tensor :class:`DrivingActor` reads has the shape of the trainer's network
    (:data:`CHANNELS`, :data:`KERNEL`, :data:`HIDDEN`; the torch loader compares every tensor with
    the network it builds, so both loaders accept the same files): ``ValueError`` naming it."""
    (w1, b1), (w2, b2) = actor.conv1, actor.conv2
    (m0, c0), (m1, c1) = actor.mlp
    head_w, head_b = actor.head
    conv, mlp = "mlp_extractor.actor_encoder.conv", "mlp_extractor.actor_mlp"
    if actor.original:  # the paper code's: one channel throughout
        kernel = ORIGINAL_KERNEL
        layers = {f"{conv}.0.weight": (w1, (1, history, kernel)), f"{conv}.0.bias": (b1, (1,)),
                  f"{conv}.1.weight": (w2, (1, 1, kernel)), f"{conv}.1.bias": (b2, (1,))}
    else:
        kernel = KERNEL
        layers = {f"{conv}.0.weight": (w1, (CHANNELS, history, KERNEL)), f"{conv}.0.bias": (b1, (CHANNELS,)),
                  f"{conv}.2.weight": (w2, (1, CHANNELS, KERNEL)), f"{conv}.2.bias": (b2, (1,))}
    wanted = {**layers,
              f"{mlp}.0.weight": (m0, (HIDDEN, m0.shape[-1] if m0.ndim == 2 and m0.shape[-1] >= pooled else -1)),
              f"{mlp}.0.bias": (c0, (HIDDEN,)), f"{mlp}.2.weight": (m1, (HIDDEN, HIDDEN)),
              f"{mlp}.2.bias": (c1, (HIDDEN,)),
              "action_net.weight": (head_w, (n_actions if n_actions is not None else head_w.shape[0], HIDDEN)),
              "action_net.bias": (head_b, (head_w.shape[0],))}
    for name, (array, shape) in wanted.items():
        if array.shape != shape:
            raise ValueError(f"{name} is {tuple(array.shape)}, the network needs "
                             f"{tuple('>= %d' % pooled if d == -1 else d for d in shape)}")
    if kernel > n_rays:
        raise ValueError(f"the convolutions' kernel {kernel} is wider than the {n_rays} rays")


def greedy_from_layers(layers: Layers, action_space: spaces.Space, obs: np.ndarray) -> np.ndarray:
    """Greedy actions of an SB3 ``MlpPolicy`` actor (tanh hidden ``layers[:-1]``, head
    ``layers[-1]``) for ``(N, D)`` observations, shaped as ``action_space`` samples."""
    x = np.asarray(obs, dtype=np.float32).reshape(len(obs), -1)
    for w, b in layers[:-1]:
        x = np.tanh(x @ w.T + b)
    w, b = layers[-1]
    out = x @ w.T + b
    if isinstance(action_space, spaces.Box):
        shape = (len(obs),) + action_space.shape
        clipped = np.clip(out, action_space.low.ravel(), action_space.high.ravel())
        return clipped.reshape(shape).astype(action_space.dtype)
    if isinstance(action_space, spaces.Discrete):
        return out.argmax(axis=1).astype(np.int64)
    if isinstance(action_space, spaces.MultiDiscrete):
        splits = np.cumsum([int(n) for n in action_space.nvec])[:-1]
        return np.stack([part.argmax(axis=1) for part in np.split(out, splits, axis=1)], axis=1).astype(np.int64)
    raise TypeError(f"unsupported action space {action_space}")


def check_spline_hidden(weights: Mapping[str, Any], declared: list[int], config: Any, file: Any) -> None:
    """The hidden layer sizes a bilevel run's ``config`` declares (``spline_hidden``) are those of
    the spline weights in ``file`` (numpy arrays or torch tensors): checked before a network of the
    declared size is built, so a config cannot make a loader allocate what it likes.
    :class:`CheckpointError` naming both otherwise."""
    saved: list[int] = []
    while f"mlp_extractor.policy_net.{2 * len(saved)}.weight" in weights:
        saved.append(int(weights[f"mlp_extractor.policy_net.{2 * len(saved)}.weight"].shape[0]))
    if saved != list(declared):
        raise CheckpointError(f"{config}: spline_hidden {list(declared)} does not match the layers of {file} "
                              f"({saved})")


def _head_size(space: spaces.Space) -> int:
    """Outputs of SB3's action head for ``space``: the logits of every category, or the mean."""
    if isinstance(space, spaces.Discrete):
        return int(space.n)
    if isinstance(space, spaces.MultiDiscrete):
        return int(np.sum(space.nvec))
    return int(np.prod(space.shape or ()))


class MlpActor:
    """An SB3 ``MlpPolicy`` actor (tanh hidden layers) from checkpoint weights: the spline
    policy of a bilevel run. ``hidden`` is how many hidden layers it has."""

    def __init__(self, weights: Mapping[str, np.ndarray], action_space: spaces.Space, hidden: int,
                 observation_space: Optional[spaces.Space] = None) -> None:
        names = [f"mlp_extractor.policy_net.{2 * k}" for k in range(hidden)] + ["action_net"]
        self.layers = linear_layers(weights, names)
        self.action_space = action_space
        width = int(np.prod(observation_space.shape or ())) if observation_space is not None else None
        for name, (w, b) in zip(names, self.layers):  # each layer reads what the one before gives
            if w.ndim != 2 or (width is not None and w.shape[1] != width) or b.shape != (w.shape[0],):
                raise ValueError(f"{name} is {w.shape} with bias {b.shape}; the layer before gives {width}")
            width = w.shape[0]
        if width != _head_size(action_space):
            raise ValueError(f"action_net gives {width} outputs, the action space {action_space} needs "
                             f"{_head_size(action_space)}")

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        return greedy_from_layers(self.layers, self.action_space, obs)
