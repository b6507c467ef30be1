"""Straight one-way highway with fixed straight tracks (the base of
``highway-spline-v0``, where each car picks its own lateral position).

The road runs from ``x = 0`` to ``x = road_length`` with ``|y| <= road_width / 2``; traffic flows
towards +x. Cars start spread along the road: car spawns take distinct random slots at
``x = spawn_start + k * spawn_slot_spacing`` (+- ``spawn_jitter``), each at a random lateral
position in ``lateral_range * W/2``, and drive straight to ``x = road_length - goal_margin``.
Each car draws an acceleration rating ``~ U[rating_range)`` that scales its accelerations and its
speed limit (``v_lim * rating``); the rating is a sat-nav extra.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from box2d_driving.config import DrivingConfig, accel_levels, require
from box2d_driving.envs.base import DrivingEnv
from box2d_driving.road.geometry import Path
from box2d_driving.road.layout import CarSpawn, LaneAxis, Layout


@dataclass(frozen=True)
class HighwayConfig(DrivingConfig):
    """Highway defaults (the paper's).

    Attributes:
        road_length: road length (m).
        road_width: road width ``W`` (m).
        x_start: x of the road's start (m).
        rating_range: acceleration rating range ``[low, high)``; equal ends fix the rating.
        spawn_start: distance of the first slot from the road's start (m).
        spawn_slot_spacing: distance between slot centres (m).
        spawn_slots: number of slots.
        spawn_jitter: uniform jitter around the slot centre along the road (m).
        lateral_range: track lateral position range, as fractions of ``W/2`` (+ = left, +y).
        goal_margin: the goal is this far before the road's end (m).
    """

    num_cars: int = 10
    horizon: int = 30
    v_lim: float = 16.0
    accelerations: tuple[float, ...] = accel_levels(-3.0, 3.0, 0.25)
    road_length: float = 250.0
    road_width: float = 25.0
    x_start: float = 0.0
    rating_range: tuple[float, float] = (0.5, 1.0)
    spawn_start: float = 5.0
    spawn_slot_spacing: float = 10.0
    spawn_slots: int = 12
    spawn_jitter: float = 2.0
    lateral_range: tuple[float, float] = (-0.75, 0.75)
    goal_margin: float = 5.0
    render_size: tuple[int, int] = (1280, 400)  # a long road: a wide frame that follows the traffic

    def _validate(self) -> None:
        require(self, 1 <= self.spawn_slots <= 64, ("spawn_slots",), "spawn_slots must be in [1, 64]")
        lo, hi = self.rating_range
        require(self, 0.0 < lo <= hi <= 1.0, ("rating_range",), "rating_range must satisfy 0 < low <= high <= 1")
        super()._validate()
        for name in ("road_length", "road_width", "spawn_slot_spacing"):
            require(self, getattr(self, name) > 0, (name,), f"{name} must be positive (m)")
        for name in ("spawn_jitter", "spawn_start", "goal_margin"):
            require(self, getattr(self, name) >= 0, (name,), f"{name} must be >= 0 m")
        require(self, self.road_width > 2 * self.car_width, ("road_width", "car_width"),
                "road_width must exceed two car widths")
        require(self, self.spawn_slot_spacing - 2 * self.spawn_jitter > self.car_length,
                ("spawn_slot_spacing", "spawn_jitter", "car_length"),
                "spawn_slot_spacing - 2 * spawn_jitter must exceed car_length (no overlap)")
        require(self, self.spawn_start - self.spawn_jitter >= self.car_length / 2,
                ("spawn_start", "spawn_jitter", "car_length"), "spawn_start - spawn_jitter must keep cars on the road")
        require(self, self.last_slot() + self.spawn_jitter + self.car_length < self.road_length - self.goal_margin,
                ("spawn_slots", "spawn_start", "spawn_slot_spacing", "spawn_jitter", "car_length", "road_length",
                 "goal_margin"),
                "spawn slots reach past the goal: fewer spawn_slots or a longer road_length")
        lat_lo, lat_hi = self.lateral_range
        limit = 1.0 - self.car_width / self.road_width
        require(self, -limit <= lat_lo <= lat_hi <= limit, ("lateral_range", "road_width", "car_width"),
                f"lateral_range must be increasing within +-{limit:.3f} (1 - car_width / road_width) "
                f"to keep cars on the road")

    _SLOTS_SET_BY = "spawn_slots"

    def max_cars(self) -> int:
        return self.spawn_slots

    def max_speed(self) -> float:
        return self.v_lim * self.rating_range[1]

    def last_slot(self) -> float:
        """Distance of the last slot centre from the road's start (m)."""
        return self.spawn_start + (self.spawn_slots - 1) * self.spawn_slot_spacing


class HighwayEnv(DrivingEnv):
    """One-way straight road; cars of different acceleration ratings on straight tracks."""

    config_class = HighwayConfig
    config: HighwayConfig  # an instance of config_class

    @property
    def satnav_extras(self) -> tuple[str, ...]:
        return ("rating",)  # the car's acceleration rating

    satnav_bounds = {"rating": (0.0, 1.0)}
    metadata = {**DrivingEnv.metadata, "name": "highway_v0"}

    def build_layout(self, rng: np.random.Generator) -> Layout:
        cfg = self.config
        x0, x1, half = cfg.x_start, cfg.x_start + cfg.road_length, cfg.road_width / 2
        edges = np.array([[[x0, -half], [x1, -half]], [[x0, half], [x1, half]]])
        drivable = [np.array([[x0, -half], [x1, -half], [x1, half], [x0, half]])]
        slots = rng.permutation(cfg.spawn_slots)[: cfg.num_cars]
        axis = LaneAxis(np.array([x0, 0.0]), np.array([1.0, 0.0]), half)
        cars = []
        for slot in slots:
            x = x0 + cfg.spawn_start + slot * cfg.spawn_slot_spacing
            x += float(rng.uniform(-cfg.spawn_jitter, cfg.spawn_jitter))
            y = float(rng.uniform(*cfg.lateral_range)) * half
            lo, hi = cfg.rating_range
            rating = float(rng.uniform(lo, hi)) if hi > lo else lo
            path = Path.straight(np.array([x, y]), np.array([x1 - cfg.goal_margin, y]))
            cars.append(CarSpawn(path=path, rating=rating, lane_axis=axis))
        return self._finish_layout(rng, Layout(edges=edges, cars=cars, drivable=drivable))

    def _finish_layout(self, rng: np.random.Generator, layout: Layout) -> Layout:
        """Hook for scenarios built on the highway (the crosswalk adds pedestrians)."""
        return layout

    def satnav_extra_values(self) -> np.ndarray:
        return self.world.ratings[:, None]
