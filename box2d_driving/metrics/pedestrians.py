"""Crosswalk metrics (slowing down for pedestrians; ``docs/crosswalk.md``).

Per sample (one car, one decision, car still driving): the distance to the nearest pedestrian
ahead (within the ``ahead_half_angle`` cone of the heading, centre to centre) and the car's speed.
A sample is safe when that distance is at least the stopping distance ``v^2 / (2 a_max)``. Also:
the share of cars that hit a pedestrian, and speed against distance to the crosswalk.
"""

from __future__ import annotations

import numpy as np

from box2d_driving.metrics.lights import outcome_rates
from box2d_driving.metrics.rollouts import COLLIDED_WITH, last_rows


def stopping_distance(speed: np.ndarray, a_max: float) -> np.ndarray:
    """``v^2 / (2 a_max)`` (m)."""
    return np.asarray(speed, dtype=float) ** 2 / (2.0 * a_max)


def pedestrian_samples(table: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Samples with a pedestrian ahead, from cars still driving (decision > 0, not done)."""
    driving = (table["decision"] > 0) & ~table["arrived"] & ~table["collided"]
    has = driving & np.isfinite(table["pedestrian_distance"])
    return {"distance": table["pedestrian_distance"][has], "speed": table["speed"][has],
            "crosswalk_distance": table["crosswalk_distance"][has]}


def crosswalk_metrics(table: dict[str, np.ndarray], a_max: float) -> dict:
    """Safe-stopping share, pedestrian collision rate, distances, plus outcome rates."""
    s = pedestrian_samples(table)
    safe = s["distance"] >= stopping_distance(s["speed"], a_max)
    rates = outcome_rates(table)
    idx = last_rows(table)
    ped_hits = table["collided_with"][idx] == COLLIDED_WITH.index("pedestrian")
    d = s["distance"]
    return {
        **rates,
        "pedestrian_collision_rate": float(ped_hits.mean()) if len(idx) else float("nan"),
        "safe_stopping_share": float(safe.mean()) if len(safe) else float("nan"),
        "samples_with_pedestrian_ahead": int(len(d)),
        "pedestrian_distance_mean": float(d.mean()) if len(d) else float("nan"),
        "pedestrian_distance_p05": float(np.percentile(d, 5)) if len(d) else float("nan"),
        "pedestrian_distance_p95": float(np.percentile(d, 95)) if len(d) else float("nan"),
        "share_more_than_6m": float(np.mean(d > 6.0)) if len(d) else float("nan"),
    }
