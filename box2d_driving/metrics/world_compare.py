"""Statistics that compare two worlds driven by the same scripted driver.

Each statistic is read from a rollout table (:mod:`box2d_driving.metrics.rollouts`), ours or one
recorded in the paper's own simulator (``box2d-driving original rollout``), so one piece of code
scores both. Each is a ratio over episodes (a share of cars, entries or decisions, or a mean over
them) with a 95 % interval from :func:`~box2d_driving.metrics.intervals.clustered_share`: the
episode is the unit of sampling, since the cars of one episode share its map and lights.

* ``entries_per_car``: junction entries per car (a car that backs out and drives in again enters
  twice);
* ``red_entry_share``, ``yellow_entry_share``: entries made on the light value 1.0 (red in the
  default colours) or 0.5 (yellow), of all entries;
* ``later_entry_share``: entries that are not the car's first;
* ``arrival_rate``: cars that reached their goal at some decision; ``arrival_decision``: the
  first such decision, over the cars that arrived;
* ``collision_rate``: cars whose last row is a collision;
* ``stop_line_speed``: speed (m/s) on the first decision a car is past its stop line, over the
  cars that passed it;
* ``light_in_view``: decisions on which the car sees a light (any value but 0.75 = none), of all
  car-decisions;
* ``lidar_returns``, ``lidar_nearest``: rays with a return per decision, and the nearest return
  (m) over the decisions with one, where the table has the noise-free LiDAR columns;
* ``heading_reading``, ``goal_reading``: what a car's sat-nav reads before it has arrived, its
  heading error to the goal (rad) and ``1 / max(distance, 1)`` (1/m), means over those
  decisions; ``arrived_heading_reading_east`` (and ``_north``, ``_west``, ``_south``): its heading
  error once arrived, by the direction it drives (from the ``heading`` column), rounded to 1e-4
  rad so that two float32 spellings of one value agree. Where the table has the sat-nav columns
  (``satnav_heading``, ``satnav_goal``). No statistic of motion sees these: a world and its
  mirror image give the same entries and crashes, but the first reading changes sign.
"""

from __future__ import annotations

from typing import Callable

import numpy as np

from box2d_driving.metrics.intervals import clustered_share
from box2d_driving.metrics.lights import junction_entries
from box2d_driving.metrics.rollouts import last_rows
from box2d_driving.road.lights import NO_LIGHT, RED, YELLOW

Units = tuple[np.ndarray, np.ndarray]  # (value per unit, its episode)
ROUNDING = 1e-9  # float summation error allowed when two estimates are compared
# relative error allowed beside it: the paper's simulator computes in float32, so a speed held at
# 4 m/s reads 3.9999995 there (a few float32 units in the last place, ~1.2e-7 each)
FLOAT32_ROUNDING = 1e-6


def _by_car(table: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """Row order by (episode, car, decision) and the start of each car's run of rows in it."""
    order = np.lexsort((table["decision"], table["car"], table["episode"]))
    ep, car = table["episode"][order], table["car"][order]
    start = np.ones(len(order), dtype=bool)
    start[1:] = (ep[1:] != ep[:-1]) | (car[1:] != car[:-1])
    return order, np.flatnonzero(start)


def _first_where(table: dict[str, np.ndarray], mask: np.ndarray) -> np.ndarray:
    """Per car, the row index of its first row (by decision) where ``mask`` holds; -1 if none."""
    order, starts = _by_car(table)
    hit = mask[order]
    out = np.full(len(starts), -1, dtype=np.int64)
    bounds = np.append(starts, len(order))
    for k in range(len(starts)):  # one pass per car: tables hold thousands of cars
        inside = np.flatnonzero(hit[bounds[k]:bounds[k + 1]])
        if len(inside):
            out[k] = order[bounds[k] + inside[0]]
    return out


def _entries(table: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    entries = junction_entries(table)
    order = np.lexsort((entries["decision"], entries["car"], entries["episode"]))
    ep, car = entries["episode"][order], entries["car"][order]
    later = np.zeros(len(order), dtype=bool)
    later[1:] = (ep[1:] == ep[:-1]) & (car[1:] == car[:-1])
    entries["later"] = np.empty(len(order), dtype=bool)
    entries["later"][order] = later
    return entries


def _entries_per_car(t: dict[str, np.ndarray]) -> Units:
    last = last_rows(t)
    e = junction_entries(t)
    key = t["episode"][last].astype(np.int64) * (int(t["car"].max(initial=0)) + 1) + t["car"][last]
    counts = dict(zip(*np.unique(e["episode"].astype(np.int64) * (int(t["car"].max(initial=0)) + 1) + e["car"],
                                 return_counts=True)))
    return np.array([counts.get(k, 0) for k in key.tolist()], dtype=float), t["episode"][last]


def _entry_share(value: float) -> Callable[[dict[str, np.ndarray]], Units]:
    def share(t: dict[str, np.ndarray]) -> Units:
        e = junction_entries(t)
        return np.isclose(e["light"], value), e["episode"]
    return share


def _later_entries(t: dict[str, np.ndarray]) -> Units:
    e = _entries(t)
    return e["later"], e["episode"]


def _arrival(t: dict[str, np.ndarray]) -> Units:
    first = _first_where(t, t["arrived"])
    order, starts = _by_car(t)
    episodes = t["episode"][order[starts]]
    return first >= 0, episodes


def _arrival_decision(t: dict[str, np.ndarray]) -> Units:
    first = _first_where(t, t["arrived"])
    rows = first[first >= 0]
    return t["decision"][rows].astype(float), t["episode"][rows]


def _collisions(t: dict[str, np.ndarray]) -> Units:
    last = last_rows(t)
    return t["collided"][last], t["episode"][last]


def _stop_line_speed(t: dict[str, np.ndarray]) -> Units:
    past = np.nan_to_num(t["stop_line_distance"], nan=np.inf) <= 0.0
    first = _first_where(t, past)
    rows = first[first >= 0]
    return t["speed"][rows].astype(float), t["episode"][rows]


def _light_in_view(t: dict[str, np.ndarray]) -> Units:
    return ~np.isclose(t["light"], NO_LIGHT), t["episode"]


def _lidar_returns(t: dict[str, np.ndarray]) -> Units:
    return t["lidar_returns"].astype(float), t["episode"]


def _lidar_nearest(t: dict[str, np.ndarray]) -> Units:
    seen = np.isfinite(t["lidar_nearest"])
    return t["lidar_nearest"][seen].astype(float), t["episode"][seen]


def _before_arrival(column: str) -> Callable[[dict[str, np.ndarray]], Units]:
    def reading(t: dict[str, np.ndarray]) -> Units:
        rows = ~t["arrived"]
        return t[column][rows].astype(float), t["episode"][rows]
    return reading


DIRECTIONS = ("east", "north", "west", "south")  # heading 0, pi/2, pi, -pi/2 (rad)


def _arrived_heading(direction: int) -> Callable[[dict[str, np.ndarray]], Units]:
    def reading(t: dict[str, np.ndarray]) -> Units:
        way = np.round(np.asarray(t["heading"], dtype=float) / (np.pi / 2)).astype(np.int64) % 4
        rows = t["arrived"] & (way == direction)
        return np.round(t["satnav_heading"][rows].astype(float), 4), t["episode"][rows]
    return reading


STATISTICS: dict[str, Callable[[dict[str, np.ndarray]], Units]] = {
    "entries_per_car": _entries_per_car,
    "red_entry_share": _entry_share(RED),
    "yellow_entry_share": _entry_share(YELLOW),
    "later_entry_share": _later_entries,
    "arrival_rate": _arrival,
    "arrival_decision": _arrival_decision,
    "collision_rate": _collisions,
    "stop_line_speed": _stop_line_speed,
    "light_in_view": _light_in_view,
    "lidar_returns": _lidar_returns,
    "lidar_nearest": _lidar_nearest,
    "heading_reading": _before_arrival("satnav_heading"),
    "goal_reading": _before_arrival("satnav_goal"),
    **{f"arrived_heading_reading_{name}": _arrived_heading(k) for k, name in enumerate(DIRECTIONS)},
}
LIDAR_COLUMNS = ("lidar_returns", "lidar_nearest")
SATNAV_COLUMNS = ("satnav_heading", "satnav_goal")
# the statistics read from the sat-nav columns, which an older recording may lack
SATNAV_STATISTICS = ("heading_reading", "goal_reading",
                     *(f"arrived_heading_reading_{name}" for name in DIRECTIONS))
# the columns each statistic needs beyond those every rollout table has
_NEEDS = {**{name: (name,) for name in LIDAR_COLUMNS},
          **{name: SATNAV_COLUMNS for name in SATNAV_STATISTICS}}


def world_statistics(table: dict[str, np.ndarray]) -> dict[str, dict[str, float]]:
    """``{"value", "half_width", "units"}`` per statistic of :data:`STATISTICS`; the LiDAR ones
    only where the table has :data:`LIDAR_COLUMNS`, the sat-nav ones where it has
    :data:`SATNAV_COLUMNS`. A statistic with no units is NaN."""
    out = {}
    for name, units in STATISTICS.items():
        if any(column not in table for column in _NEEDS.get(name, ())):
            continue
        values, episodes = units(table)
        value, _, half = clustered_share(values, episodes)
        out[name] = {"value": value, "half_width": half, "units": int(len(values))}
    return out


def agree(a: dict[str, float], b: dict[str, float]) -> bool:
    """Whether two estimates' difference lies within its 95 % interval (the half-widths added in
    quadrature: independent blocks of episodes), give or take :data:`ROUNDING` (a mean of equal
    values summed in another order can differ in its last digits) and :data:`FLOAT32_ROUNDING` of
    the larger magnitude (one world computing in float32)."""
    slack = ROUNDING + FLOAT32_ROUNDING * max(abs(a["value"]), abs(b["value"]))
    return abs(a["value"] - b["value"]) <= float(np.hypot(a["half_width"], b["half_width"])) + slack
