"""The per-episode road layout a scenario produces and the env turns into a Box2D world."""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

import numpy as np

from box2d_driving.road.geometry import Path, points_in_box, points_in_polygon
from box2d_driving.road.lights import TrafficLights


@dataclass(frozen=True)
class LaneAxis:
    """The road axis a car's lane position is measured from.

    ``offset = (p - origin) . right(direction) / half_width``: positive on the right-hand side of
    the direction of travel, +-1 at the road edges.
    """

    origin: np.ndarray
    direction: np.ndarray
    half_width: float

    @property
    def right(self) -> np.ndarray:
        """Unit vector to the right of the direction of travel."""
        return np.array([self.direction[1], -self.direction[0]])

    def offset(self, positions: np.ndarray) -> np.ndarray:
        """Signed normalised lane offset of each position ``(..., 2)`` (m): positive right of the
        direction of travel, +-1 at the road edges."""
        return (np.asarray(positions) - self.origin) @ self.right / self.half_width


@dataclass(frozen=True)
class CarSpawn:
    """One car: the path it follows from its spawn point (arc length ``start_s``, by default 0,
    the path's start) to its goal (arc length ``goal_s``, by default the path's end).

    Attributes:
        path: the track.
        light_index: index of the light controlling its approach, -1 if none.
        rating: acceleration rating; scales accelerations and the speed limit.
        lane_axis: for the signed normalised lane offset.
        approach: index of the approach (road) it starts on, -1 if not meaningful.
        start_s: arc length of the spawn point (m); a path that starts behind it lets a car
            reverse (``reverse``).
        goal_s: arc length at which the car counts as arrived (m); None: the path's end. A path
            that goes on past it lets an arrived car drive on (``arrived_cars_stay``).
        goal: the goal point the sat-nav points at, ``(2,)`` (m); None: the path's last point.
    """

    path: Path
    light_index: int = -1
    rating: float = 1.0
    lane_axis: Optional[LaneAxis] = None
    approach: int = -1
    start_s: float = 0.0
    goal_s: Optional[float] = None
    goal: Optional[np.ndarray] = None


@dataclass(frozen=True)
class PedestrianSpawn:
    """A square pedestrian (side ``size``, m) walking at constant velocity (m/s) until it leaves
    ``y_bounds``; then it turns back (``turn_back``) or stands still there."""

    position: np.ndarray
    velocity: np.ndarray
    y_bounds: tuple[float, float]
    size: float = 0.8
    turn_back: bool = True


@dataclass(frozen=True)
class Layout:
    """Everything a scenario decides for one episode.

    Attributes:
        edges: ``(E, 2, 2)`` road-edge segments (m).
        cars: one spawn per car, in agent order.
        pedestrians: pedestrians on the crosswalk.
        lights: the junction's lights, or None.
        junction_box: ``(xmin, ymin, xmax, ymax)`` of the junction, or None.
        crosswalk: ``(xmin, ymin, xmax, ymax)`` of the crosswalk, or None.
        drivable: polygons ``(K, 2)`` of drivable surface, for drawing.
        stop_lines: ``(S, 2, 2)`` stop-line segments, for drawing.
        junction_polygon: ``(K, 2)`` outline of the junction area; when given it defines
            :meth:`in_junction` instead of ``junction_box`` (real junctions).
        crosswalks: crosswalk polygons ``(4, 2)``, for drawing.
        name: the map's name (real junctions), else empty.
    """

    edges: np.ndarray
    cars: list[CarSpawn]
    pedestrians: list[PedestrianSpawn] = field(default_factory=list)
    lights: Optional[TrafficLights] = None
    junction_box: Optional[tuple[float, float, float, float]] = None
    crosswalk: Optional[tuple[float, float, float, float]] = None
    drivable: list[np.ndarray] = field(default_factory=list)
    stop_lines: np.ndarray = field(default_factory=lambda: np.zeros((0, 2, 2)))
    junction_polygon: Optional[np.ndarray] = None
    crosswalks: list[np.ndarray] = field(default_factory=list)
    name: str = ""

    def in_junction(self, positions: np.ndarray) -> np.ndarray:
        """Whether each position lies inside the junction area."""
        if self.junction_polygon is not None:
            return points_in_polygon(np.asarray(positions, dtype=np.float64), self.junction_polygon)
        if self.junction_box is None:
            return np.zeros(len(positions), dtype=bool)
        return points_in_box(positions, self.junction_box)
