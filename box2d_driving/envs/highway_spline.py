"""Highway where each car picks its own lateral position: fast lanes are not
given (the paper's fast-lane experiment).

Cars start on the road axis, spread along it. Stage 0 observes the car's acceleration rating and
picks one continuous lateral target ``a in [-1, 1]``: the car's path is the centripetal
Catmull-Rom spline from its spawn point through ``(x_spawn + lane_change_distance,
a * spline_lateral_limit * W/2)`` to its goal at the same lateral position (+ = left, +y, as the
highway's ``lateral_range``).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from gymnasium import spaces

from box2d_driving.config import require
from box2d_driving.envs.highway import HighwayConfig, HighwayEnv
from box2d_driving.envs.spline import SplineStageMixin
from box2d_driving.road.geometry import spline_paths
from box2d_driving.road.layout import Layout


@dataclass(frozen=True)
class HighwaySplineConfig(HighwayConfig):
    """Spline-highway defaults.

    Attributes:
        lateral_range: cars spawn on the road axis.
        spline_lateral_limit: the largest lateral target, as a fraction of ``W/2`` (the paper's
            0.75).
        lane_change_distance: distance along the road over which a car reaches its target (m).
        spline_samples: Catmull-Rom samples per spline segment.
    """

    lateral_range: tuple[float, float] = (0.0, 0.0)
    spline_lateral_limit: float = 0.75
    lane_change_distance: float = 30.0
    spline_samples: int = 32

    def _validate(self) -> None:
        super()._validate()
        limit = 1.0 - self.car_width / self.road_width
        require(self, 0.0 <= self.spline_lateral_limit <= limit, ("spline_lateral_limit", "road_width", "car_width"),
                f"spline_lateral_limit must lie in [0, {limit:.3f}] to keep cars on the road")
        require(self, self.lane_change_distance > 0, ("lane_change_distance",),
                "lane_change_distance must be positive (m)")
        goal = self.road_length - self.goal_margin
        require(self, self.last_slot() + self.spawn_jitter + self.lane_change_distance < goal,
                ("lane_change_distance", "spawn_slots", "spawn_start", "spawn_slot_spacing", "spawn_jitter",
                 "road_length", "goal_margin"),
                "lane_change_distance reaches past the goal from the last spawn slot")
        require(self, 4 <= self.spline_samples <= 1000, ("spline_samples",), "spline_samples must be in [4, 1000]")


class HighwaySplineEnv(SplineStageMixin, HighwayEnv):
    """The highway with a stage-0 lateral target per car (see the module docstring)."""

    config_class = HighwaySplineConfig
    config: HighwaySplineConfig  # an instance of config_class
    metadata = {**HighwayEnv.metadata, "name": "highway_spline_v0"}

    def __init__(self, **overrides) -> None:
        super().__init__(**overrides)
        self.spline_action_space = spaces.Box(-1.0, 1.0, shape=(1,), dtype=np.float32)
        self.spline_observation_space = spaces.Box(0.0, 1.0, shape=(1,), dtype=np.float32)

    def spline_observation_values(self, layout: Layout) -> np.ndarray:
        return np.array([[c.rating] for c in layout.cars])

    def lateral_targets(self, actions: np.ndarray) -> np.ndarray:
        """Lateral target ``y`` (m) of each car for stage-0 ``actions`` ``(N, 1)``."""
        cfg = self.config
        a = np.clip(np.asarray(actions, dtype=np.float64).reshape(-1), -1.0, 1.0)
        return a * cfg.spline_lateral_limit * cfg.road_width / 2

    def apply_spline(self, layout: Layout, actions: np.ndarray) -> Layout:
        cfg = self.config
        targets = self.lateral_targets(actions)
        starts = np.array([car.path.points[0] for car in layout.cars]).reshape(-1, 2)
        goal_x = np.array([car.path.points[-1][0] for car in layout.cars])
        # per car: its start, the point one lane-change distance on at its target, the goal's x there
        control = np.stack([starts, np.column_stack([starts[:, 0] + cfg.lane_change_distance, targets]),
                            np.column_stack([goal_x, targets])], axis=1)
        paths = spline_paths(control, samples_per_segment=cfg.spline_samples)
        cars = [dataclasses.replace(car, path=path) for car, path in zip(layout.cars, paths)]
        return dataclasses.replace(layout, cars=cars)
