"""Traffic-light metrics (``docs/traffic_lights.md``).

For every car that enters the junction box, the light value it saw last before entering (its
observation on the decision before the first decision it is inside). The two light groups are
symmetric, so a policy may adopt either 0.0 or 1.0 as "stop": the stop value is the one of
{0.0, 1.0} on which fewer entries happen, and the red-light violation rate is the share of all
entries made on it. A light-blind policy enters on both about equally, so it scores a little under
one half (every car at full throttle, 200 report episodes: 0.415 with one car, 0.448 with four).

Why a car entered on the stop value (:func:`violation_causes`): on the decision it first saw its
light leave the go value (yellow or the stop value, without the go value again before entering),
either it was already inside its braking distance of the stop line and could not have stopped
there (the light changed too late for it: the world's share), or it could have stopped and did not
(the policy's share).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from box2d_driving.metrics.rollouts import last_rows
from box2d_driving.road.lights import GREEN, NO_LIGHT, RED, YELLOW

GO_STOP = (0.0, 1.0)


@dataclass(frozen=True)
class Violations:
    """Violation rate, the adopted stop value, and entry counts per light value."""

    rate: float
    stop_value: float
    entries: int
    counts: dict[float, int]


def _entry_rows(table: dict[str, np.ndarray]) -> tuple[np.ndarray, np.ndarray]:
    """The table's row order by (episode, car, decision) and, in that order, the index of the row
    before each junction entry (the car outside, its next row inside)."""
    order = np.lexsort((table["decision"], table["car"], table["episode"]))
    ep, car = table["episode"][order], table["car"][order]
    inside = table["in_junction"][order]
    same = (ep[1:] == ep[:-1]) & (car[1:] == car[:-1])
    return order, np.flatnonzero(same & inside[1:] & ~inside[:-1])


def junction_entries(table: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """One row per junction entry: ``episode``, ``car``, ``decision`` (first inside),
    ``light`` (seen on the decision before), ``x``, ``y`` (where it was then)."""
    order, enter = _entry_rows(table)
    first_inside = order[enter + 1]
    before = order[enter]
    return {
        "episode": table["episode"][first_inside], "car": table["car"][first_inside],
        "decision": table["decision"][first_inside],
        "light": table["light"][before],
        "x": table["x"][before], "y": table["y"][before],
    }


def violation_rate(entry_lights: np.ndarray) -> Violations:
    """Red-light violation rate from the light values seen at junction entries."""
    lights = np.asarray(entry_lights, dtype=float)
    counts = {v: int(np.sum(np.isclose(lights, v))) for v in (GREEN, YELLOW, NO_LIGHT, RED)}
    if len(lights) == 0:
        return Violations(float("nan"), 1.0, 0, counts)
    stop = min(GO_STOP, key=lambda v: (counts[v], -v))  # ties: 1.0 (red) is "stop"
    return Violations(counts[stop] / len(lights), stop, len(lights), counts)


@dataclass(frozen=True)
class ViolationCauses:
    """Entries on the stop value by whether the car could still have stopped.

    Attributes:
        violations: entries on the stop value.
        could_not_stop: on the decision the car first saw yellow or the stop value (the run of
            those values that ends at its entry), its braking distance ``v^2 / (2 b)`` was longer
            than its distance to the stop line: braking hard from then on it would still have
            crossed the line.
        could_have_stopped: it had room to stop before the line then, and entered anyway.
        unknown: no stop-line distance on that decision (no light on the car's approach).
        collided: violators whose episode ended in a collision.
    """

    violations: int
    could_not_stop: int
    could_have_stopped: int
    unknown: int
    collided: int


def violation_causes(table: dict[str, np.ndarray], stop_value: float, max_brake: float) -> ViolationCauses:
    """Split the entries made on ``stop_value`` by whether the car could have stopped (see
    :class:`ViolationCauses`). ``max_brake``: the hardest braking of a rating-1 car (m/s^2, > 0);
    a car brakes at ``max_brake * rating``. Reads the columns ``speed`` (m/s),
    ``stop_line_distance`` (m from the car's centre to its stop line, positive before it) and
    ``rating``."""
    if not max_brake > 0:
        raise ValueError(f"max_brake must be > 0 m/s^2, got {max_brake!r}")
    order, enter = _entry_rows(table)
    ep, car, light = table["episode"][order], table["car"][order], table["light"][order]
    speed, dist = table["speed"][order], table["stop_line_distance"][order]
    rating, collided = table["rating"][order], table["collided"][order]
    ends = np.flatnonzero(np.append((ep[1:] != ep[:-1]) | (car[1:] != car[:-1]), True))  # each car's last row
    not_go = np.isclose(light, YELLOW) | np.isclose(light, stop_value)
    could_not = could = unknown = crashed = 0
    for j in enter[np.isclose(light[enter], stop_value)].tolist():
        first = j  # walk back over the run of yellow / stop values that ends at the entry
        while first > 0 and ep[first - 1] == ep[j] and car[first - 1] == car[j] and not_go[first - 1]:
            first -= 1
        d = dist[first]
        if not np.isfinite(d):
            unknown += 1
        elif speed[first] ** 2 / (2.0 * max_brake * rating[first]) > d:
            could_not += 1
        else:
            could += 1
        crashed += bool(collided[ends[np.searchsorted(ends, j)]])
    return ViolationCauses(could_not + could + unknown, could_not, could, unknown, crashed)


def outcome_rates(table: dict[str, np.ndarray]) -> dict[str, float]:
    """Success and collision rates over cars (their last rows: where cars stay after arriving,
    ``arrived`` stays true and a later crash counts too), and mean time to goal (decisions) of
    arrivals: each arrived car's first decision with ``arrived`` set."""
    idx = last_rows(table)
    arrived = table["arrived"][idx]
    collided = table["collided"][idx]
    times = _arrival_decisions(table)
    return {
        "cars": int(len(idx)),
        "success_rate": float(arrived.mean()) if len(idx) else float("nan"),
        "collision_rate": float(collided.mean()) if len(idx) else float("nan"),
        "mean_time_to_goal": float(times.mean()) if len(times) else float("nan"),
    }


def _arrival_decisions(table: dict[str, np.ndarray]) -> np.ndarray:
    """The first decision with ``arrived`` set of every car that arrived, cars ordered by (episode,
    car) as :func:`last_rows` orders them."""
    rows = np.flatnonzero(table["arrived"])
    order = rows[np.lexsort((table["decision"][rows], table["car"][rows], table["episode"][rows]))]
    ep, car = table["episode"][order], table["car"][order]
    first = np.ones(len(order), dtype=bool)
    first[1:] = (ep[1:] != ep[:-1]) | (car[1:] != car[:-1])
    return table["decision"][order[first]]


def traffic_light_metrics(table: dict[str, np.ndarray], max_brake: float | None = None) -> dict:
    """The lights summary: outcome rates plus the violation rate with its convention; with
    ``max_brake`` (m/s^2, the env's hardest braking), also the violations split by whether the car
    could have stopped (:func:`violation_causes`), as shares of all entries."""
    entries = junction_entries(table)
    v = violation_rate(entries["light"])
    causes = {}
    if max_brake is not None:
        c = violation_causes(table, v.stop_value, max_brake)
        nan = float("nan")
        causes = {"violations_could_not_stop_rate": c.could_not_stop / v.entries if v.entries else nan,
                  "violations_could_have_stopped_rate": c.could_have_stopped / v.entries if v.entries else nan,
                  "violations_unknown_cause": c.unknown,
                  "violators_collision_rate": c.collided / c.violations if c.violations else nan}
    return {
        **outcome_rates(table),
        "red_light_violation_rate": v.rate,
        "stop_value": v.stop_value,
        "junction_entries": v.entries,
        "entries_by_light": {str(k): c for k, c in v.counts.items()},
        **causes,
    }
