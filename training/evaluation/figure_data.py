"""The small distributions a results page draws, computed from an evaluation's rollouts.

A sweep trial stores these beside its metrics (``summary.json``), so the results page redraws the
paper's distribution figures from the committed summaries alone: fixed bins, counts only, a few
hundred numbers per trial at most.
"""

from __future__ import annotations

from typing import Any

import numpy as np

# fixed bins, the same for every trial so that counts add up across seeds
LANE_BINS = np.linspace(-1.0, 1.0, 25)          # normalised lane position, + = right
PEDESTRIAN_BINS = np.linspace(0.0, 40.0, 21)    # m to the nearest pedestrian ahead
GAP_BINS = np.linspace(0.0, 40.0, 21)           # m to the car ahead
CLOSING_BINS = np.linspace(0.0, 12.0, 13)       # m/s closing speed


def to_majority_side(name: str, counts: np.ndarray) -> np.ndarray:
    """One trial's counts of distribution ``name``, mirrored where the side a run settles on is
    its own choice: lane positions with more samples left of the axis than right are flipped, so
    that trials summed over seeds show how one-sided each is, not which side each picked."""
    counts = np.asarray(counts, dtype=float)
    if name == "lane_position_counts":
        half = len(counts) // 2  # LANE_BINS are symmetric about the axis
        if counts[:half].sum() > counts[len(counts) - half:].sum():
            return counts[::-1].copy()
    return counts


def _counts(values: np.ndarray, bins: np.ndarray) -> list[int]:
    values = np.asarray(values, dtype=float)
    values = values[np.isfinite(values)]
    return np.histogram(np.clip(values, bins[0], bins[-1]), bins=bins)[0].astype(int).tolist()


def figure_data(env_id: str, table: dict[str, np.ndarray], config: Any) -> dict[str, Any]:
    """Histogram counts for the scenario's figure: lane positions inside the junction (lanes),
    distance to the pedestrian ahead (crosswalk), gap against closing speed to the car ahead
    (real junctions). Bins are the module's constants."""
    out: dict[str, Any] = {}
    if env_id == "intersection-spline-v0":
        from box2d_driving.metrics.lanes import junction_lane_samples

        out["lane_position_counts"] = _counts(junction_lane_samples(table), LANE_BINS)
    elif env_id == "crosswalk-v0":
        from box2d_driving.metrics.pedestrians import pedestrian_samples

        out["pedestrian_distance_counts"] = _counts(pedestrian_samples(table)["distance"], PEDESTRIAN_BINS)
    elif env_id == "real-junction-v0":
        from box2d_driving.metrics.right_of_way import leader_samples

        s = leader_samples(table, config.car_length, wrecks_stay=config.wrecks_stay)
        closing = s["closing_speed"] > 0
        gap = np.clip(s["gap"][closing], GAP_BINS[0], GAP_BINS[-1])
        speed = np.clip(s["closing_speed"][closing], CLOSING_BINS[0], CLOSING_BINS[-1])
        counts = np.histogram2d(gap, speed, bins=[GAP_BINS, CLOSING_BINS])[0]
        out["gap_closing_counts"] = counts.astype(int).tolist()
    return out
