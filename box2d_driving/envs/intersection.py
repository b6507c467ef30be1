"""Four-way signalled junction with fixed straight tracks (the traffic-lights experiment).

Geometry (per episode): four arms of length ``L ~ U[road_length_range)`` and width
``W ~ U[road_width_range)`` around a ``W x W`` junction box centred at the origin. Approach ``a``
(0: from the west, 1: south, 2: east, 3: north) drives in direction ``(cos a*pi/2, sin a*pi/2)``
on the right-hand side of the road (``lane_fraction * W/2`` right of the axis) from its spawn slot
to a goal on the opposite road ``0.5 * (goal_fraction * L + W)`` from the centre (with ``turns``,
on the road it turns into: see :mod:`box2d_driving.road.turns`). Car ``i`` starts
on approach ``i % 4`` (round-robin) in a random free slot; slots sit ``spawn_first_slot +
k * spawn_slot_spacing`` (+- ``spawn_jitter``) before the stop line, which is the junction box's
edge. Lights: approaches 0 and 2 form group 0, approaches 1 and 3 group 1.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import numpy as np

from box2d_driving.config import ConfigError, DrivingConfig, require
from box2d_driving.envs.base import DrivingEnv
from box2d_driving.road.geometry import Path
from box2d_driving.road.layout import CarSpawn, LaneAxis, Layout
from box2d_driving.road.lights import sample_lights
from box2d_driving.road.turns import exit_direction, paper_turning_track, turning_track

N_APPROACHES = 4
SPAWN_MODES = ("slots", "arm")
DRIVE_SIDES = ("right", "left")
LIGHT_VIEWS = ("stop_line", "axis_point")
APPROACH_ORDERS = ("fixed", "rotate", "random")
TURN_MOTIONS = ("circle", "paper")


@dataclass(frozen=True)
class IntersectionConfig(DrivingConfig):
    """Intersection defaults (the paper's, with the horizon raised to satisfy the timing
    invariant; see :meth:`worst_case_arrival_time`).

    Attributes:
        road_length_range: arm length ``L`` range (m).
        road_width_range: road width ``W`` range (m).
        lane_fraction: track offset right of the road axis, as a fraction of ``W/2``.
        goal_fraction: the goal lies ``0.5 * (goal_fraction * L + W)`` from the centre.
        spawn_first_slot: distance of the nearest slot's centre before the stop line (m).
        spawn_slot_spacing: distance between slot centres (m).
        slots_per_approach: slots on each approach.
        spawn_jitter: uniform jitter of a car around its slot centre (m).
        spawn_mode: ``"slots"`` (the slots above) or ``"arm"`` (the paper's code: anywhere on its
            arm, ``U[arm_spawn_range) * L`` before the junction, cars on one arm redrawn until
            they do not overlap).
        arm_spawn_range: with ``"arm"`` spawns, the spawn distance before the junction as
            fractions of the arm length ``L`` (the paper's code: the middle 60 % of the arm).
        lane_offset_range: the track's offset right of the road axis drawn per car from
            ``U[low, high) * W`` (the paper's code: 0.15-0.30); None: ``lane_fraction * W/2``.
        approach_order: ``"fixed"`` (car ``i`` on approach ``i % 4``), ``"rotate"`` (round robin
            from a random approach, the paper's code with ``balance_cars``) or ``"random"`` (each
            car's approach uniform, the paper's code without it).
        goal_radius: None: a car arrives at the end of its track, ``0.5 * (goal_fraction * L +
            W)`` past the centre on its lane. A number ``r``: the goal is that point on the road
            axis, and a car arrives once within ``r * W`` of it (the paper's code: 1/3).
        road_end_walls: the far end of every arm is a wall (the paper's code), which a car that
            drives on past its goal (``arrived_cars_stay``) or backs up (``reverse``) can hit.
        drive_on: the side of the road the cars keep to, with their stop lines and lights:
            ``"right"``, or ``"left"`` (the paper's code: the mirror image, which its scripted
            drivers cannot tell apart but a trained policy's LiDAR and heading error can). Lane
            offsets (``lane_offset`` in rollouts) stay positive to the right of travel.
        light_view: where a car sees its approach's light from: ``"stop_line"``, while its centre
            is within ``light_view_distance`` before its stop line, measured along the approach,
            facing the way it drives; or ``"axis_point"`` (the paper's code), while its centre is
            within that straight-line distance of the point where its arm's axis meets the
            junction, until it passes that point's line (a car off the axis sees the light later).
        turns: each car leaves by one of the three other roads, drawn uniformly (straight on, left
            or right; the paper's code's ``turns=True``), turning on a quarter circle about a
            junction corner and keeping its side of the road; False: every car goes straight on.
            The lights stay two merged phases, read by the road a car comes from (as in the
            paper's code with ``learn_right_of_way``); lane offsets are read on that road's axis.
        turn_motion: how a turning car moves: ``"circle"``, along the quarter circle at its
            speed; ``"paper"``, as the paper's code moves it (its heading turns by the arc driven
            over a quarter circle's length, in radians; its position read off the circle at that
            heading for the circle's first radian, then moving along that heading until it points
            down the new road: :func:`box2d_driving.road.turns.paper_turning_track`). Needs
            ``goal_radius`` (the car need not come out on its lane).
    """

    horizon: int = 36
    road_length_range: tuple[float, float] = (55.0, 80.0)
    road_width_range: tuple[float, float] = (15.0, 30.0)
    lane_fraction: float = 0.5
    goal_fraction: float = 0.67
    spawn_first_slot: float = 8.0
    spawn_slot_spacing: float = 8.0
    slots_per_approach: int = 4
    spawn_jitter: float = 1.0
    spawn_mode: str = "slots"
    arm_spawn_range: tuple[float, float] = (0.2, 0.8)
    lane_offset_range: Optional[tuple[float, float]] = None
    approach_order: str = "fixed"
    goal_radius: Optional[float] = None
    road_end_walls: bool = False
    drive_on: str = "right"
    light_view: str = "stop_line"
    turns: bool = False
    turn_motion: str = "circle"

    def _validate(self) -> None:
        require(self, 1 <= self.slots_per_approach <= 16, ("slots_per_approach",),
                "slots_per_approach must be in [1, 16]")
        super()._validate()
        lo_l, hi_l = self.road_length_range
        lo_w, hi_w = self.road_width_range
        require(self, 0 < lo_l < hi_l, ("road_length_range",), "road_length_range must be increasing and positive (m)")
        require(self, 0 < lo_w < hi_w, ("road_width_range",), "road_width_range must be increasing and positive (m)")
        require(self, lo_w / 2 >= self.car_width, ("road_width_range", "car_width"),
                "roads must be at least two car widths wide")
        for name in ("spawn_jitter", "spawn_first_slot", "spawn_slot_spacing"):
            require(self, getattr(self, name) >= 0, (name,), f"{name} must be >= 0 m")
        require(self, self.spawn_first_slot - self.spawn_jitter >= self.car_length / 2,
                ("spawn_first_slot", "spawn_jitter", "car_length"),
                "spawn_first_slot - spawn_jitter must leave the car behind the stop line")
        require(self, self.spawn_slot_spacing - 2 * self.spawn_jitter > self.car_length,
                ("spawn_slot_spacing", "spawn_jitter", "car_length"),
                "spawn_slot_spacing - 2 * spawn_jitter must exceed car_length (no overlap)")
        require(self, self.farthest_spawn() + self.car_length / 2 <= lo_l,
                ("slots_per_approach", "spawn_first_slot", "spawn_slot_spacing", "spawn_jitter", "car_length",
                 "road_length_range"),
                f"the farthest spawn slot ({self.farthest_spawn():.1f} m before the stop line) must fit "
                f"on the shortest road")
        require(self, 0.0 <= self.lane_fraction <= 1.0 - self.car_width / lo_w,
                ("lane_fraction", "car_width", "road_width_range"), "lane_fraction must keep the track on the road")
        require(self, 0.0 < self.goal_fraction <= 1.0, ("goal_fraction",), "goal_fraction must be in (0, 1]")
        require(self, self.spawn_mode in SPAWN_MODES, ("spawn_mode",), f"spawn_mode must be one of {SPAWN_MODES}")
        require(self, self.approach_order in APPROACH_ORDERS, ("approach_order",),
                f"approach_order must be one of {APPROACH_ORDERS}")
        require(self, self.drive_on in DRIVE_SIDES, ("drive_on",), f"drive_on must be one of {DRIVE_SIDES}")
        require(self, self.light_view in LIGHT_VIEWS, ("light_view",), f"light_view must be one of {LIGHT_VIEWS}")
        require(self, self.turn_motion in TURN_MOTIONS, ("turn_motion",), f"turn_motion must be one of {TURN_MOTIONS}")
        require(self, self.turn_motion == "circle" or self.goal_radius is not None, ("turn_motion", "goal_radius"),
                "turn_motion='paper' needs goal_radius (the paper's code's goal test)")
        a_lo, a_hi = self.arm_spawn_range
        require(self, 0.0 <= a_lo < a_hi <= 1.0 and a_lo * lo_l >= self.car_length / 2,
                ("arm_spawn_range", "road_length_range", "car_length"),
                "arm_spawn_range must be increasing within [0, 1] and keep a car on its arm")
        if self.lane_offset_range is not None:
            o_lo, o_hi = self.lane_offset_range
            require(self, 0.0 <= o_lo < o_hi and o_hi * hi_w <= hi_w / 2 - self.car_width / 2
                    and o_hi <= 0.5 - self.car_width / lo_w, ("lane_offset_range", "car_width", "road_width_range"),
                    "lane_offset_range must be increasing, >= 0 and keep the car on its side of the road")
        if self.goal_radius is not None:
            widest = self.lane_offset_range[1] if self.lane_offset_range is not None else self.lane_fraction / 2
            require(self, widest < self.goal_radius <= 0.5, ("goal_radius", "lane_offset_range", "lane_fraction"),
                    "goal_radius must exceed the largest track offset (in road widths) and be <= 0.5")

    _SLOTS_SET_BY = "slots_per_approach, 4 approaches"

    def max_cars(self) -> int:
        return N_APPROACHES * self.slots_per_approach

    def farthest_spawn(self) -> float:
        """Largest distance of a car's centre before the stop line at spawn (m)."""
        return self.spawn_first_slot + (self.slots_per_approach - 1) * self.spawn_slot_spacing + self.spawn_jitter

    def worst_case_arrival_time(self) -> float:
        """Seconds a car needs in the worst case: spawned at the farthest slot on the largest
        map, it drives to the stop line and stops there, waits a full red (``T_max - yellow``),
        then drives to its goal (with ``turns``, by the longest turn); at ``v_lim`` and the
        largest acceleration. The timing invariant asks this to fit in the horizon (with a
        decision of slack per phase)."""
        a, v = max(self.accelerations), self.v_lim
        d_stop = self.farthest_spawn()
        t_stop = 2 * v / a + (d_stop - v * v / a) / v if d_stop >= v * v / a else 2 * math.sqrt(d_stop / a)
        d_go = self.road_width_range[1] + 0.5 * self.goal_fraction * self.road_length_range[1]
        if self.turns:  # the longest turn (across the road) beside crossing the junction straight
            half = self.road_width_range[1] / 2
            lane = self.lane_fraction * half if self.lane_offset_range is None \
                else self.lane_offset_range[1] * self.road_width_range[1]
            d_go += max(0.0, 0.5 * math.pi * (half + lane) - 2 * half)
        t_go = v / a + (d_go - v * v / (2 * a)) / v if d_go >= v * v / (2 * a) else math.sqrt(2 * d_go / a)
        return t_stop + (self.light_period_range[1] - self.light_yellow) + t_go


class IntersectionEnv(DrivingEnv):
    """Signalled four-way junction; cars drive straight across on fixed tracks."""

    config_class = IntersectionConfig
    config: IntersectionConfig  # an instance of config_class
    n_lights = N_APPROACHES
    metadata = {**DrivingEnv.metadata, "name": "intersection_v0"}

    def build_layout(self, rng: np.random.Generator) -> Layout:
        cfg = self.config
        length = float(rng.uniform(*cfg.road_length_range))
        width = float(rng.uniform(*cfg.road_width_range))
        half = width / 2
        dirs = np.array([[math.cos(a * math.pi / 2), math.sin(a * math.pi / 2)]
                         for a in range(N_APPROACHES)])
        rights = np.stack([dirs[:, 1], -dirs[:, 0]], axis=1)
        # the side the cars keep to: the right of travel, or its mirror image
        sides = rights if cfg.drive_on == "right" else -rights

        edges, drivable = [], [np.array([[-half, -half], [half, -half], [half, half], [-half, half]])]
        for u, r in zip(dirs, rights):  # arm pointing along u
            for side in (-1.0, 1.0):
                edges.append([u * half + side * r * half, u * (half + length) + side * r * half])
            drivable.append(np.array([u * half - r * half, u * (half + length) - r * half,
                                      u * (half + length) + r * half, u * half + r * half]))

        lane = cfg.lane_fraction * half
        stop_points = -half * dirs + lane * sides
        stop_lines = np.stack([-half * dirs, -half * dirs + half * sides], axis=1)
        lights = sample_lights(rng, stop_points, dirs, np.arange(N_APPROACHES) % 2,
                               cfg.light_period_range, cfg.light_yellow, cfg.light_start, cfg.light_period_step,
                               cfg.light_first_green)
        if cfg.road_end_walls:  # across the far end of every arm
            edges += [[u * (half + length) - r * half, u * (half + length) + r * half] for u, r in zip(dirs, rights)]

        goal_dist = 0.5 * (cfg.goal_fraction * length + width)
        if cfg.spawn_mode == "arm" or cfg.approach_order != "fixed" or cfg.lane_offset_range is not None \
                or cfg.goal_radius is not None or cfg.arrived_cars_stay or cfg.reverse or cfg.turns:
            cars = self._paper_spawns(rng, length, width, dirs, sides, goal_dist)
            return Layout(edges=np.array(edges), cars=cars, lights=lights,
                          junction_box=(-half, -half, half, half), drivable=drivable, stop_lines=stop_lines)
        free = [list(rng.permutation(cfg.slots_per_approach)) for _ in range(N_APPROACHES)]
        cars = []
        for i in range(cfg.num_cars):
            a = i % N_APPROACHES
            slot = int(free[a].pop())
            back = half + cfg.spawn_first_slot + slot * cfg.spawn_slot_spacing
            back += float(rng.uniform(-cfg.spawn_jitter, cfg.spawn_jitter))
            d, r = dirs[a], sides[a]
            path = Path.straight(-back * d + lane * r, goal_dist * d + lane * r)
            cars.append(CarSpawn(path=path, light_index=a, rating=1.0,
                                 lane_axis=LaneAxis(np.zeros(2), d.copy(), half), approach=a))
        return Layout(edges=np.array(edges), cars=cars, lights=lights,
                      junction_box=(-half, -half, half, half), drivable=drivable,
                      stop_lines=stop_lines)

    def _paper_spawns(self, rng: np.random.Generator, length: float, width: float, dirs: np.ndarray,
                      sides: np.ndarray, goal_dist: float) -> list[CarSpawn]:
        """Spawns by the options the paper's code uses (``spawn_mode``, ``lane_offset_range``,
        ``approach_order``, ``goal_radius``) on straight tracks; a track reaches back to the start
        arm's far end when cars ``reverse`` and on to the goal arm's far end when they stay after
        arriving (``arrived_cars_stay``), so either motion stays on it."""
        cfg = self.config
        half = width / 2
        first = int(rng.integers(N_APPROACHES)) if cfg.approach_order == "rotate" else 0
        free = [list(rng.permutation(cfg.slots_per_approach)) for _ in range(N_APPROACHES)] \
            if cfg.spawn_mode == "slots" else None
        placed: list[tuple[int, float, float]] = []  # approach, distance before the centre, offset
        cars = []
        for i in range(cfg.num_cars):
            for _ in range(_MAX_SPAWN_TRIES):
                if cfg.approach_order == "fixed":
                    a = i % N_APPROACHES
                elif cfg.approach_order == "rotate":
                    a = (first + 1 + i) % N_APPROACHES
                else:
                    a = int(rng.integers(N_APPROACHES))
                if cfg.lane_offset_range is None:
                    lane = cfg.lane_fraction * half
                else:
                    lane = float(rng.uniform(*cfg.lane_offset_range)) * width
                if free is not None:  # spawn_mode "slots"
                    if not free[a]:
                        continue
                    back = half + cfg.spawn_first_slot + int(free[a].pop()) * cfg.spawn_slot_spacing
                    back += float(rng.uniform(-cfg.spawn_jitter, cfg.spawn_jitter))
                else:
                    back = half + float(rng.uniform(*cfg.arm_spawn_range)) * length
                if all(b != a or abs(bk - back) >= cfg.car_length or abs(o - lane) >= cfg.car_width
                       for b, bk, o in placed):
                    break
            else:
                raise ConfigError(f"{type(cfg).__name__}: no free spawn for car {i} after {_MAX_SPAWN_TRIES} draws "
                                  f"(num_cars={cfg.num_cars} on arms of {length:.0f} m): use fewer cars")
            placed.append((a, back, lane))
            d, r = dirs[a], sides[a]
            far = half + length
            turn = _TURNS[int(rng.integers(len(_TURNS)))] if cfg.turns else 0
            if turn != 0:
                cars.append(self._turning_spawn(a, d, r, lane, half, width, back, far, goal_dist, turn))
                continue
            start = (-far if cfg.reverse else -back) * d + lane * r
            if cfg.goal_radius is None:
                goal = goal_dist * d + lane * r
                goal_s = goal_dist + (far if cfg.reverse else back)
            else:
                goal = goal_dist * d
                reach = math.sqrt((cfg.goal_radius * width) ** 2 - lane ** 2)
                goal_s = goal_dist - reach + (far if cfg.reverse else back)
            end = (far if cfg.arrived_cars_stay else (goal_dist if cfg.goal_radius is None else goal_s
                                                     - (far if cfg.reverse else back))) * d + lane * r
            cars.append(CarSpawn(path=Path.straight(start, end), light_index=a, rating=1.0,
                                 lane_axis=LaneAxis(np.zeros(2), d.copy(), half), approach=a,
                                 start_s=(far - back) if cfg.reverse else 0.0, goal_s=goal_s, goal=goal))
        return cars

    def _turning_spawn(self, a: int, d: np.ndarray, side: np.ndarray, lane: float, half: float, width: float,
                       back: float, far: float, goal_dist: float, turn: int) -> CarSpawn:
        """The spawn of a car from approach ``a`` (direction ``d``, ``lane`` m towards ``side``)
        that turns left (``turn`` 1) or right (-1): its goal on the road it turns into, as a
        straight-on car's is on the opposite road."""
        cfg = self.config
        out = exit_direction(d, turn)
        start = far if cfg.reverse else back
        end = far if cfg.arrived_cars_stay else goal_dist
        if cfg.turn_motion == "paper":
            assert cfg.goal_radius is not None  # _validate
            goal = goal_dist * out
            path = paper_turning_track(d, side, lane, half, start - half, out, far)
            goal_s = _first_within(path, goal, cfg.goal_radius * width, path.cumlen[1])
            if not cfg.arrived_cars_stay and goal_s <= path.length:
                path = _cut(path, goal_s)
            return CarSpawn(path=path, light_index=a, rating=1.0, lane_axis=LaneAxis(np.zeros(2), d.copy(), half),
                            approach=a, start_s=(far - back) if cfg.reverse else 0.0, goal_s=goal_s, goal=goal)
        path, leave_s = turning_track(d, side, lane, half, start - half, out, end - half)
        leave = path.pose(leave_s)[0]
        if cfg.goal_radius is None:
            goal = leave + (goal_dist - half) * out
            goal_s = leave_s + goal_dist - half
        else:  # the goal on the road's axis, reached within goal_radius * W of it
            goal = goal_dist * out
            reach = math.sqrt((cfg.goal_radius * width) ** 2 - lane ** 2)
            goal_s = leave_s + goal_dist - half - reach
            if not cfg.arrived_cars_stay:
                path = Path.from_points(np.concatenate([path.points[:-1], [leave + (goal_s - leave_s) * out]]))
        return CarSpawn(path=path, light_index=a, rating=1.0, lane_axis=LaneAxis(np.zeros(2), d.copy(), half),
                        approach=a, start_s=(far - back) if cfg.reverse else 0.0, goal_s=goal_s, goal=goal)


def _first_within(path: Path, point: np.ndarray, radius: float, s_from: float, step: float = 0.1,
                  fine: float = 0.001) -> float:
    """The first arc length from ``s_from`` at which ``path`` comes within ``radius`` (m) of
    ``point``, to ``fine`` m; past the path's end (never) if it does not. A position moves at
    most as far as the arc length (``cumlen`` is at least the polyline's length), so between
    samples ``step`` apart the distance dips at most ``step / 2`` below theirs: only samples
    within ``radius + step / 2`` are searched finely."""
    s = np.arange(s_from, path.length + step, step)
    pos, _ = path.pose(s)
    near = np.flatnonzero(np.hypot(pos[:, 0] - point[0], pos[:, 1] - point[1]) <= radius + step / 2)
    for i in near:
        grid = np.arange(max(s_from, s[i] - step), min(s[i] + step, path.length) + fine, fine)
        pos, _ = path.pose(grid)
        inside = np.flatnonzero(np.hypot(pos[:, 0] - point[0], pos[:, 1] - point[1]) <= radius)
        if len(inside):
            return float(min(grid[inside[0]], path.length))
    return path.length + 1.0


def _cut(path: Path, s_end: float) -> Path:
    """``path`` up to arc length ``s_end``."""
    keep = path.cumlen < s_end
    end, _ = path.pose(s_end)
    return Path(np.concatenate([path.points[keep], [end]]), np.concatenate([path.cumlen[keep], [s_end]]))


# a turning car's draw: straight on, left, right (the paper's code: the three other roads)
_TURNS = (0, 1, -1)

# draws of one car's spawn before it is given up (a crowded arm)
_MAX_SPAWN_TRIES = 1000
