"""Highway with a crosswalk and pedestrians (``docs/crosswalk.md``).

The road spans ``x in [-road_length/2, road_length/2]``; the crosswalk covers
``x in crosswalk_x`` across the road. Between ``pedestrians_range`` pedestrians (0.8 m squares)
spawn at random non-overlapping points on the crosswalk, the walkway included, each walking across
the road (+y or -y) at ``U[pedestrian_speed_range)``. By default each crosses once and stands still
on the far walkway (the paper: "the pedestrians cross the road with a constant velocity"), so the
crosswalk empties over the episode; ``pedestrians_turn_back=True`` makes them walk back and forth.
The LiDAR sees them; hitting one is a collision.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from box2d_driving.config import accel_levels, require
from box2d_driving.envs.base import DrivingEnv
from box2d_driving.envs.highway import HighwayConfig, HighwayEnv
from box2d_driving.road.geometry import wrap_angle
from box2d_driving.road.layout import Layout, PedestrianSpawn

_SPAWN_TRIES = 200


@dataclass(frozen=True)
class CrosswalkConfig(HighwayConfig):
    """Crosswalk defaults (the paper's).

    Attributes:
        crosswalk_x: crosswalk extent along the road (m).
        walkway: how far beyond each road edge pedestrians walk before turning back (m).
        pedestrians_range: the number of pedestrians is uniform in ``[low, high]``.
        pedestrian_speed_range: walking speed range ``[low, high)`` (m/s).
        pedestrian_size: pedestrian square side (m).
        ahead_half_angle: a pedestrian within this angle of a car's heading is "ahead" (rad).
        pedestrians_turn_back: pedestrians walk back and forth instead of crossing once.
        crosswalk_in_satnav: add ``crosswalk_ahead`` to the sat-nav (the map knows where the
            crosswalk is; not in the paper, whose cars can tell their position along the road
            only from ``1 / distance_to_goal``): ``1 - d / crosswalk_view`` for the distance
            ``d`` from the car's front to the crosswalk (clipped to [0, 1]), 1 on it, 0 once past.
        crosswalk_view: range of ``crosswalk_ahead`` (m).
    """

    num_cars: int = 4
    horizon: int = 30
    v_lim: float = 10.0
    accelerations: tuple[float, ...] = accel_levels(-3.0, 3.0, 0.25)
    road_length: float = 140.0
    x_start: float = -70.0
    rating_range: tuple[float, float] = (1.0, 1.0)
    spawn_slots: int = 5
    crosswalk_x: tuple[float, float] = (-10.0, 10.0)
    walkway: float = 2.0
    pedestrians_range: tuple[int, int] = (1, 10)
    pedestrian_speed_range: tuple[float, float] = (1.0, 2.0)
    pedestrian_size: float = 0.8
    ahead_half_angle: float = math.pi / 6
    pedestrians_turn_back: bool = False
    crosswalk_in_satnav: bool = False
    crosswalk_view: float = 50.0

    def _validate(self) -> None:
        super()._validate()
        lo, hi = self.pedestrians_range
        require(self, 0 <= lo <= hi <= 100, ("pedestrians_range",),
                "pedestrians_range must satisfy 0 <= low <= high <= 100")
        s_lo, s_hi = self.pedestrian_speed_range
        require(self, 0 < s_lo <= s_hi, ("pedestrian_speed_range",),
                "pedestrian_speed_range must be positive and increasing (m/s)")
        require(self, 0.05 <= self.pedestrian_size <= 10, ("pedestrian_size",),
                "pedestrian_size must be in [0.05, 10] m (Box2D cannot make a smaller body)")
        require(self, 0 < self.walkway, ("walkway",), "walkway must be positive (m)")
        require(self, 0 < self.ahead_half_angle <= math.pi, ("ahead_half_angle",),
                "ahead_half_angle must be in (0, pi] rad")
        c0, c1 = self.crosswalk_x
        require(self, self.x_start < c0 < c1 < self.x_start + self.road_length,
                ("crosswalk_x", "x_start", "road_length"), "crosswalk_x must be increasing and lie on the road")
        require(self, self.crosswalk_view > 0, ("crosswalk_view",), "crosswalk_view must be positive (m)")
        require(self, c1 - c0 >= self.pedestrian_size, ("crosswalk_x", "pedestrian_size"),
                "the crosswalk must be wider than a pedestrian")
        require(self, self.x_start + self.last_slot() + self.spawn_jitter + self.car_length / 2 < c0,
                ("spawn_slots", "spawn_start", "spawn_slot_spacing", "spawn_jitter", "x_start", "crosswalk_x"),
                "spawn slots reach the crosswalk: fewer spawn_slots or a crosswalk farther along")

    def max_obstacle_speed(self) -> float:
        return self.pedestrian_speed_range[1]

    def min_obstacle_size(self) -> float:
        return self.pedestrian_size


class CrosswalkEnv(HighwayEnv):
    """Highway with pedestrians crossing; cars must see them with the LiDAR and slow down."""

    config_class = CrosswalkConfig
    config: CrosswalkConfig  # an instance of config_class
    satnav_bounds = {"crosswalk_ahead": (0.0, 1.0)}

    @property
    def satnav_extras(self) -> tuple[str, ...]:
        return ("crosswalk_ahead",) if self.config.crosswalk_in_satnav else ()
    metadata = {**DrivingEnv.metadata, "name": "crosswalk_v0"}

    def _finish_layout(self, rng: np.random.Generator, layout: Layout) -> Layout:
        cfg = self.config
        size = cfg.pedestrian_size
        y_max = cfg.road_width / 2 + cfg.walkway
        count = int(rng.integers(cfg.pedestrians_range[0], cfg.pedestrians_range[1] + 1))
        peds: list[PedestrianSpawn] = []
        for _ in range(_SPAWN_TRIES):
            if len(peds) == count:
                break
            p = np.array([rng.uniform(cfg.crosswalk_x[0] + size / 2, cfg.crosswalk_x[1] - size / 2),
                          rng.uniform(-y_max, y_max)])
            speed = float(rng.uniform(*cfg.pedestrian_speed_range))
            direction = 1.0 if rng.random() < 0.5 else -1.0
            if all(np.max(np.abs(p - q.position)) > size for q in peds):
                peds.append(PedestrianSpawn(p, np.array([0.0, direction * speed]), (-y_max, y_max), size,
                                            cfg.pedestrians_turn_back))
        half = cfg.road_width / 2
        crosswalk = (cfg.crosswalk_x[0], -half, cfg.crosswalk_x[1], half)
        return dataclasses.replace(layout, pedestrians=peds, crosswalk=crosswalk)

    def satnav_extra_values(self) -> np.ndarray:
        cfg = self.config
        if not cfg.crosswalk_in_satnav:
            return np.zeros((cfg.num_cars, 0))
        w = self.world
        front = self._bumper_x(w.positions, w.headings, +1.0)
        rear = self._bumper_x(w.positions, w.headings, -1.0)
        ahead = np.clip(1.0 - (cfg.crosswalk_x[0] - front) / cfg.crosswalk_view, 0.0, 1.0)
        return np.where(rear > cfg.crosswalk_x[1], 0.0, ahead)[:, None]

    def _bumper_x(self, pos: np.ndarray, head: np.ndarray, side: float) -> np.ndarray:
        """x (m) of the front (``side=+1``) or rear (``-1``) bumper centre of cars at ``pos``, ``head``."""
        return pos[:, 0] + side * 0.5 * self.config.car_length * np.cos(head)

    scenario_info_fields = {
        "pedestrian_distance": "centre distance to the nearest pedestrian within `ahead_half_angle` of the "
                               "heading (m; None if none)",
        "crosswalk_distance": "from the car's front to the near edge of the crosswalk (m, negative once the "
                              "front is past it)",
    }

    def scenario_info(self, cars: np.ndarray) -> list[dict]:
        """``pedestrian_distance``: centre distance (m) to the nearest pedestrian within
        ``ahead_half_angle`` of the heading (None if none); ``crosswalk_distance``: from the car's
        front to the near edge of the crosswalk (m, negative once the front is past it)."""
        cfg, w = self.config, self.world
        pos, head = w.positions[cars], w.headings[cars]
        front = self._bumper_x(pos, head, +1.0)
        out = [{"crosswalk_distance": float(cfg.crosswalk_x[0] - f), "pedestrian_distance": None}
               for f in front]
        if len(w.ped_positions):
            rel = w.ped_positions[None, :, :] - pos[:, None, :]
            dist = np.linalg.norm(rel, axis=2)
            bearing = np.arctan2(rel[..., 1], rel[..., 0]) - head[:, None]
            bearing = wrap_angle(bearing)
            dist = np.where(np.abs(bearing) <= cfg.ahead_half_angle, dist, np.inf)
            nearest = dist.min(axis=1)
            for j, d in enumerate(nearest):
                if np.isfinite(d):
                    out[j]["pedestrian_distance"] = float(d)
        return out
