"""Observation layout and frame history.

An observation is one flat float32 vector::

    [ LiDAR frame t-H+1 | ... | LiDAR frame t | sat-nav frame t-H+1 | ... | sat-nav frame t ]

with ``H = history`` frames, oldest first (at reset the first frame is repeated). A LiDAR frame has
``n_rays`` values (ray 0 along the heading, counter-clockwise). A sat-nav frame has the fields named
in :attr:`ObservationLayout.satnav_fields`: the light seen, ``speed / v_lim``, the heading error to
the goal (rad, in ``[-pi, pi]``), ``1 / max(distance_to_goal, 1)``, then scenario extras.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit


@dataclass(frozen=True)
class ObservationLayout:
    """Where each part of the flat observation lives.

    Attributes:
        history: frames stacked (oldest first).
        n_rays: LiDAR values per frame.
        satnav_fields: names of the sat-nav values per frame.
    """

    history: int
    n_rays: int
    satnav_fields: tuple[str, ...]

    @property
    def n_satnav(self) -> int:
        return len(self.satnav_fields)

    @property
    def lidar(self) -> slice:
        """Slice of the whole LiDAR history (``history * n_rays`` values)."""
        return slice(0, self.history * self.n_rays)

    @property
    def satnav(self) -> slice:
        """Slice of the whole sat-nav history (``history * n_satnav`` values)."""
        start = self.history * self.n_rays
        return slice(start, start + self.history * self.n_satnav)

    @property
    def size(self) -> int:
        return self.history * (self.n_rays + self.n_satnav)

    def split(self, obs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``(..., size)`` observations to LiDAR ``(..., history, n_rays)`` and sat-nav
        ``(..., history, n_satnav)`` arrays."""
        obs = np.asarray(obs)
        lead = obs.shape[:-1]
        return (obs[..., self.lidar].reshape(*lead, self.history, self.n_rays),
                obs[..., self.satnav].reshape(*lead, self.history, self.n_satnav))

    def field(self, name: str) -> int:
        """Index of a sat-nav field within a frame."""
        return self.satnav_fields.index(name)

    def newest(self, name: str) -> int:
        """Index in the flat observation of a sat-nav field's newest reading (the last frame)."""
        return self.satnav.start + (self.history - 1) * self.n_satnav + self.field(name)


class FrameHistory:
    """Rolling ``(N, H, F)`` buffers of LiDAR and sat-nav frames for N cars."""

    def __init__(self, layout: ObservationLayout, n_cars: int) -> None:
        self.layout = layout
        self.lidar = np.zeros((n_cars, layout.history, layout.n_rays), dtype=np.float32)
        self.satnav = np.zeros((n_cars, layout.history, layout.n_satnav), dtype=np.float32)

    def reset(self, lidar: np.ndarray, satnav: np.ndarray) -> None:
        self.lidar[:] = lidar[:, None, :]
        self.satnav[:] = satnav[:, None, :]

    def push(self, cars: np.ndarray, lidar: np.ndarray, satnav: np.ndarray) -> None:
        """Append a frame for the cars listed in ``cars`` (indices, no repeats), dropping their
        oldest."""
        cars = np.asarray(cars, dtype=np.int64)
        _push(self.lidar, cars, np.asarray(lidar, dtype=np.float32))
        _push(self.satnav, cars, np.asarray(satnav, dtype=np.float32))

    def observations(self, cars: np.ndarray) -> np.ndarray:
        """Flat ``(len(cars), size)`` observations."""
        out = np.empty((len(cars), self.layout.size), dtype=np.float32)
        _flatten(self.lidar, self.satnav, np.asarray(cars, dtype=np.int64), out)
        return out


# compiled: both run for every car every decision, and a handful of numpy fancy-index calls on
# these small arrays cost more than the copies themselves
@njit(cache=True)
def _push(frames, cars, new):
    """Shift each listed car's ``(H, F)`` frames one place older and write ``new[k]`` last."""
    history = frames.shape[1]
    for k in range(cars.shape[0]):
        c = cars[k]
        for h in range(history - 1):
            frames[c, h, :] = frames[c, h + 1, :]
        frames[c, history - 1, :] = new[k]


@njit(cache=True)
def _flatten(lidar, satnav, cars, out):
    """Row ``k`` of ``out``: car ``cars[k]``'s LiDAR frames then its sat-nav frames, oldest first."""
    n_lidar = lidar.shape[1] * lidar.shape[2]
    for k in range(cars.shape[0]):
        out[k, :n_lidar] = lidar[cars[k]].ravel()
        out[k, n_lidar:] = satnav[cars[k]].ravel()
