"""The small distributions a results page draws, as counts in fixed bins.

A sweep trial stores these beside its metrics, so the results page redraws the paper's
distribution figures from committed summaries alone: fixed bins (the same for every trial, so
counts add up across seeds), counts only, a few hundred numbers per trial at most. A scenario's
record (:mod:`box2d_driving.scenarios`) names the function for its figure.
"""

from __future__ import annotations

from typing import Any

import numpy as np

LANE_BINS = np.linspace(-1.0, 1.0, 25)          # normalised lane position, + = right
PEDESTRIAN_BINS = np.linspace(0.0, 40.0, 21)    # m to the nearest pedestrian ahead
GAP_BINS = np.linspace(0.0, 40.0, 21)           # m to the car ahead
CLOSING_BINS = np.linspace(0.0, 12.0, 13)       # m/s closing speed


def counts_in(values: np.ndarray, bins: np.ndarray) -> list[int]:
    """Counts of the finite ``values`` in ``bins``, values beyond either end counted in the end bin."""
    values = np.asarray(values, dtype=float)
    values = values[np.isfinite(values)]
    return np.histogram(np.clip(values, bins[0], bins[-1]), bins=bins)[0].astype(int).tolist()


def lane_positions(table: dict[str, np.ndarray], config: Any = None) -> dict[str, Any]:
    """Lane positions inside the junction (``lane_position_counts``, :data:`LANE_BINS`)."""
    from box2d_driving.metrics.lanes import junction_lane_samples

    return {"lane_position_counts": counts_in(junction_lane_samples(table), LANE_BINS)}


def pedestrian_distances(table: dict[str, np.ndarray], config: Any = None) -> dict[str, Any]:
    """Distance to the nearest pedestrian ahead (``pedestrian_distance_counts``, m)."""
    from box2d_driving.metrics.pedestrians import pedestrian_samples

    return {"pedestrian_distance_counts": counts_in(pedestrian_samples(table)["distance"], PEDESTRIAN_BINS)}


def gaps_and_closing_speeds(table: dict[str, np.ndarray], config: Any) -> dict[str, Any]:
    """Gap to the car ahead against closing speed, where closing (``gap_closing_counts``, a 2-D
    count over :data:`GAP_BINS` x :data:`CLOSING_BINS`)."""
    from box2d_driving.metrics.right_of_way import leader_samples

    s = leader_samples(table, config.car_length, wrecks_stay=config.wrecks_stay)
    closing = s["closing_speed"] > 0
    gap = np.clip(s["gap"][closing], GAP_BINS[0], GAP_BINS[-1])
    speed = np.clip(s["closing_speed"][closing], CLOSING_BINS[0], CLOSING_BINS[-1])
    counts = np.histogram2d(gap, speed, bins=[GAP_BINS, CLOSING_BINS])[0]
    return {"gap_closing_counts": counts.astype(int).tolist()}
