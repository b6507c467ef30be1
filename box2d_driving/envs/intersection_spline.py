"""Signalled junction where each car picks its own path: lanes are not given (the
paper's lane-emergence experiment; ``docs/lanes.md``).

The planned route of a car runs along the road axis through three waypoints: its spawn point,
the junction centre and its goal. Stage 0 offsets each waypoint sideways by one of
``spline_offsets * W/2`` to the right or to the left of the direction of travel: 6 choices per
waypoint (zero appears once per side, as in the paper's count), ``6**3 = 216`` discrete actions.
The car then follows the centripetal Catmull-Rom spline through the three offset points.

The choice ``k_j`` in ``[0, 6)`` for waypoint ``j`` (0: spawn, 1: centre, 2: goal) means side =
right if ``k_j < 3`` else left, size = ``spline_offsets[k_j % 3]``. ``spline_action="per_waypoint"``
(default) makes the action space ``MultiDiscrete([6, 6, 6])``: the same 216 paths, with a policy
that factorises over the waypoints (one softmax per waypoint: far fewer samples to learn a side
than one 216-way softmax). ``spline_action="joint"`` is one ``Discrete(216)`` index
``a = k_0 + 6 k_1 + 36 k_2``.

Stage-0 observation (per car, metres / ``spline_obs_scale``): the three route waypoints in the
car's frame (origin at the planned spawn, x along the direction of travel) and ``W/2``.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from gymnasium import spaces

from box2d_driving.config import require
from box2d_driving.envs.intersection import IntersectionConfig, IntersectionEnv
from box2d_driving.envs.spline import SplineStageMixin
from box2d_driving.road.geometry import spline_paths
from box2d_driving.road.layout import LaneAxis, Layout

N_WAYPOINTS = 3


@dataclass(frozen=True)
class IntersectionSplineConfig(IntersectionConfig):
    """Spline-junction defaults.

    Attributes:
        num_cars: 8, the paper's lanes experiment (cars only settle on a side when the junction is busy).
        lidar_noise: 0.5, the same experiment's LiDAR (half the rays dropped each decision).
        lane_fraction: the planned route runs on the road axis (0).
        spline_offsets: waypoint offset sizes as fractions of ``W/2``, each offered to the right
            and to the left.
        spline_action: ``"per_waypoint"`` (MultiDiscrete 6 x 6 x 6) or ``"joint"`` (Discrete 216).
        spline_samples: Catmull-Rom samples per spline segment.
        spline_obs_scale: stage-0 observations are metres divided by this.
    """

    num_cars: int = 8
    lidar_noise: float = 0.5
    lane_fraction: float = 0.0
    spline_offsets: tuple[float, ...] = (0.0, 1 / 3, 2 / 3)
    spline_action: str = "per_waypoint"
    spline_samples: int = 32
    spline_obs_scale: float = 100.0

    def _validate(self) -> None:
        super()._validate()
        limit = 1.0 - self.car_width / self.road_width_range[0]
        require(self, bool(self.spline_offsets) and min(self.spline_offsets) >= 0 and max(self.spline_offsets) <= limit
                and len(self.spline_offsets) <= 16, ("spline_offsets", "road_width_range", "car_width"),
                f"spline_offsets must be 1 to 16 values in [0, {limit:.3f}] to keep cars on the road")
        require(self, self.spline_action in ("per_waypoint", "joint"), ("spline_action",),
                "spline_action must be 'per_waypoint' or 'joint'")
        require(self, 4 <= self.spline_samples <= 1000, ("spline_samples",), "spline_samples must be in [4, 1000]")
        require(self, self.spline_obs_scale > 0, ("spline_obs_scale",), "spline_obs_scale must be positive")
        # the routes are planned with offsets to the right of travel and its stop lines there
        require(self, self.drive_on == "right", ("drive_on",), "the spline stage plans routes on the right: drive_on "
                "must be 'right'")
        require(self, self.light_view == "stop_line", ("light_view",), "the spline stage's routes leave the road "
                "axis its light_view='axis_point' measures from: light_view must be 'stop_line'")

    @property
    def choices_per_waypoint(self) -> int:
        return 2 * len(self.spline_offsets)

    @property
    def n_spline_actions(self) -> int:
        return self.choices_per_waypoint ** N_WAYPOINTS


class IntersectionSplineEnv(SplineStageMixin, IntersectionEnv):
    """The signalled junction with stage-0 path choice (see the module docstring)."""

    config_class = IntersectionSplineConfig
    config: IntersectionSplineConfig  # an instance of config_class
    metadata = {**IntersectionEnv.metadata, "name": "intersection_spline_v0"}

    def __init__(self, **overrides) -> None:
        super().__init__(**overrides)
        cfg = self.config
        c = cfg.choices_per_waypoint
        self.spline_action_space = (spaces.Discrete(cfg.n_spline_actions) if cfg.spline_action == "joint"
                                    else spaces.MultiDiscrete([c] * N_WAYPOINTS))
        self.spline_observation_space = spaces.Box(-np.inf, np.inf, shape=(2 * N_WAYPOINTS + 1,),
                                                   dtype=np.float32)

    def decode_offsets(self, actions: np.ndarray) -> np.ndarray:
        """``(N, 3)`` signed waypoint offsets (fractions of ``W/2``, + = right) of ``actions``:
        joint indices ``(N,)`` or per-waypoint choices ``(N, 3)``."""
        cfg = self.config
        c, m = cfg.choices_per_waypoint, len(cfg.spline_offsets)
        actions = np.asarray(actions, dtype=np.int64)
        digits = actions if actions.ndim == 2 else (actions[:, None] // c ** np.arange(N_WAYPOINTS)) % c
        sizes = np.asarray(cfg.spline_offsets)[digits % m]
        return np.where(digits < m, sizes, -sizes)

    def encode_offsets(self, choices: np.ndarray) -> np.ndarray:
        """Inverse of :meth:`decode_offsets` on choice digits ``(N, 3)`` in ``[0, 6)``."""
        c = self.config.choices_per_waypoint
        return (np.asarray(choices, dtype=np.int64) * c ** np.arange(N_WAYPOINTS)).sum(axis=1)

    def _waypoints(self, layout: Layout) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Route waypoints ``(N, 3, 2)``, directions and right vectors ``(N, 2)``."""
        starts = np.array([c.path.points[0] for c in layout.cars])
        goals = np.array([c.path.points[-1] for c in layout.cars])
        dirs = np.array([a.direction for a in _axes(layout)])
        rights = np.array([a.right for a in _axes(layout)])
        centre = np.array([a.origin for a in _axes(layout)])  # the junction centre
        return np.stack([starts, centre, goals], axis=1), dirs, rights

    def spline_observation_values(self, layout: Layout) -> np.ndarray:
        cfg = self.config
        wps, dirs, rights = self._waypoints(layout)
        rel = wps - wps[:, :1]
        local = np.stack([np.einsum("nkj,nj->nk", rel, dirs), np.einsum("nkj,nj->nk", rel, -rights)], axis=2)
        half = np.array([a.half_width for a in _axes(layout)])
        return np.concatenate([local.reshape(len(wps), -1), half[:, None]], axis=1) / cfg.spline_obs_scale

    def apply_spline(self, layout: Layout, actions: np.ndarray) -> Layout:
        cfg = self.config
        wps, _, rights = self._waypoints(layout)
        offsets = self.decode_offsets(actions)
        half = np.array([a.half_width for a in _axes(layout)])
        control = wps + (offsets * half[:, None])[:, :, None] * rights[:, None, :]
        paths = spline_paths(control, samples_per_segment=cfg.spline_samples)
        cars = [dataclasses.replace(car, path=path) for car, path in zip(layout.cars, paths)]
        return dataclasses.replace(layout, cars=cars)


def _axes(layout: Layout) -> list[LaneAxis]:
    """Each car's lane axis (every spline junction car has one: its route is laid along it)."""
    axes = [c.lane_axis for c in layout.cars]
    missing = [i for i, a in enumerate(axes) if a is None]
    if missing:
        raise ValueError(f"cars {missing} have no lane axis to lay a spline route along")
    return [a for a in axes if a is not None]
