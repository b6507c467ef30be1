"""Traffic-light metrics (``docs/traffic_lights.md``).

For every car that enters the junction box, the light value it saw last before entering (its
observation on the decision before the first decision it is inside). The two light groups are
symmetric, so a policy may adopt either 0.0 or 1.0 as "stop": the stop value is the one of
{0.0, 1.0} on which fewer entries happen, and the red-light violation rate is the share of all
entries made on it. A light-blind policy enters on both about equally, so it scores a little under
one half (every car at full throttle, 200 report episodes: 0.415 with one car, 0.448 with four).
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


def junction_entries(table: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """One row per junction entry: ``episode``, ``car``, ``decision`` (first inside),
    ``light`` (seen on the decision before), ``x``, ``y`` (where it was then)."""
    order = np.lexsort((table["decision"], table["car"], table["episode"]))
    ep, car = table["episode"][order], table["car"][order]
    inside = table["in_junction"][order]
    same = (ep[1:] == ep[:-1]) & (car[1:] == car[:-1])
    enter = np.flatnonzero(same & inside[1:] & ~inside[:-1])  # index of the row before entering
    first_inside = enter + 1
    return {
        "episode": ep[first_inside], "car": car[first_inside],
        "decision": table["decision"][order][first_inside],
        "light": table["light"][order][enter],
        "x": table["x"][order][enter], "y": table["y"][order][enter],
    }


def violation_rate(entry_lights: np.ndarray) -> Violations:
    """Red-light violation rate from the light values seen at junction entries."""
    lights = np.asarray(entry_lights, dtype=float)
    counts = {v: int(np.sum(np.isclose(lights, v))) for v in (GREEN, YELLOW, NO_LIGHT, RED)}
    if len(lights) == 0:
        return Violations(float("nan"), 1.0, 0, counts)
    stop = min(GO_STOP, key=lambda v: (counts[v], -v))  # ties: 1.0 (red) is "stop"
    return Violations(counts[stop] / len(lights), stop, len(lights), counts)


def outcome_rates(table: dict[str, np.ndarray]) -> dict[str, float]:
    """Success and collision rates over cars, and mean time to goal (decisions) of arrivals."""
    idx = last_rows(table)
    arrived = table["arrived"][idx]
    collided = table["collided"][idx]
    times = table["decision"][idx][arrived]
    return {
        "cars": int(len(idx)),
        "success_rate": float(arrived.mean()) if len(idx) else float("nan"),
        "collision_rate": float(collided.mean()) if len(idx) else float("nan"),
        "mean_time_to_goal": float(times.mean()) if len(times) else float("nan"),
    }


def traffic_light_metrics(table: dict[str, np.ndarray]) -> dict:
    """The lights summary: outcome rates plus the violation rate with its convention."""
    entries = junction_entries(table)
    v = violation_rate(entries["light"])
    return {
        **outcome_rates(table),
        "red_light_violation_rate": v.rate,
        "stop_value": v.stop_value,
        "junction_entries": v.entries,
        "entries_by_light": {str(k): c for k, c in v.counts.items()},
    }
