"""What a car's LiDAR reports from its distances: the rays lost to noise, and the encoding.

LiDAR noise drops a fixed share of each car's rays every decision (``round(noise * n_rays)`` of
them, chosen uniformly at random from the env's generator; ``"exact"``), or each ray on its own
with probability ``noise`` (``"independent"``, the paper's code); a dropped ray reads as no return. The
observation then holds one value per ray (:func:`encode`): ``inverse`` (``1 / d``, the paper's) or
``proximity`` (``1 - d / range``), 0 for no return.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from box2d_driving.config import LIDAR_ENCODINGS


def dropout_mask(rng: np.random.Generator, n_cars: int, n_rays: int, noise: float) -> np.ndarray:
    """``(n_cars, n_rays)`` boolean mask with exactly ``round(noise * n_rays)`` True per row,
    chosen uniformly at random (the rays to drop)."""
    return dropout_from_draws(dropout_draws(rng, n_cars, n_rays, noise), n_cars, n_rays, noise)


def _dropped_per_row(n_rays: int, noise: float) -> int:
    return int(math.floor(noise * n_rays + 0.5))


def dropout_draws(rng: np.random.Generator, n_cars: int, n_rays: int, noise: float,
                  mode: str = "exact") -> np.ndarray:
    """The random draws :func:`dropout_mask` takes from ``rng``: ``(n_cars, n_rays)`` uniforms,
    or an empty ``(0, n_rays)`` array where the mask needs none (nothing or everything dropped;
    with ``"independent"`` dropout, nothing)."""
    if mode == "independent":
        return rng.random((n_cars, n_rays)) if noise > 0.0 and n_cars else np.zeros((0, n_rays))
    k = _dropped_per_row(n_rays, noise)
    if k == 0 or k >= n_rays or n_cars == 0:
        return np.zeros((0, n_rays))
    return rng.random((n_cars, n_rays))


def dropout_from_draws(draws: np.ndarray, n_cars: int, n_rays: int, noise: float,
                       mode: str = "exact") -> np.ndarray:
    """The dropout mask of ``n_cars`` rows from their :func:`dropout_draws` (rows of several
    generators' draws may be stacked: each row's mask depends on that row alone)."""
    if mode == "independent":  # a ray is kept where its draw exceeds the noise, as in the paper's code
        return draws <= noise if len(draws) else np.zeros((n_cars, n_rays), dtype=bool)
    k = _dropped_per_row(n_rays, noise)
    if k == 0 or n_cars == 0:
        return np.zeros((n_cars, n_rays), dtype=bool)
    if k >= n_rays:
        return np.ones((n_cars, n_rays), dtype=bool)
    # the k smallest draws of each row (draws are distinct doubles: exactly k per row)
    return draws <= np.partition(draws, k - 1, axis=1)[:, k - 1:k]


# Hits closer than this (m) read as this distance, so the inverse encoding is bounded by
# 1 / MIN_DISTANCE. Rays start at the car's centre, at least half a car width (1.1 m) from anything
# it has not crashed into: only a car already overlapping something sees a closer hit.
MIN_DISTANCE = 0.1


def encode(distances: np.ndarray, max_range: float, encoding: str,
           dropped: np.ndarray | None = None) -> np.ndarray:
    """Distances (m, any shape) to float32 observation values; no return (``inf``) and the rays
    marked in ``dropped`` (a boolean mask of the same shape, optional) become 0.
    ``inverse``: ``1 / d`` with ``d`` at least :data:`MIN_DISTANCE` (so at most 10 per metre);
    ``proximity``: ``1 - d / range``."""
    if encoding not in LIDAR_ENCODINGS:
        raise ValueError(f"unknown LiDAR encoding {encoding!r}; expected one of {LIDAR_ENCODINGS}")
    distances = np.asarray(distances, dtype=np.float64)
    shape = distances.shape
    flat = np.ascontiguousarray(distances).reshape(-1)
    if dropped is None:
        mask = np.zeros(len(flat), dtype=np.bool_)
    else:
        mask = np.ascontiguousarray(dropped, dtype=np.bool_).reshape(-1)
    out = np.empty(len(flat), dtype=np.float32)
    _encode(flat, mask, float(max_range), encoding == "inverse", out)
    return out.reshape(shape)


@njit(cache=True)
def _encode(distances, dropped, max_range, inverse, out):
    """:func:`encode` compiled over the flattened distances (every car every decision): each value
    worked out in float64 and rounded once to float32, as numpy's whole-array version did."""
    for i in range(distances.shape[0]):
        d = distances[i]
        if dropped[i] or not math.isfinite(d):
            out[i] = 0.0
        elif inverse:
            out[i] = 1.0 / max(d, MIN_DISTANCE)
        else:
            out[i] = 1.0 - d / max_range
