"""The small distributions a results page draws, computed from an evaluation's rollouts.

A sweep trial stores these beside its metrics (``summary.json``), so the results page redraws the
paper's distribution figures from the committed summaries alone: fixed bins, counts only, a few
hundred numbers per trial at most.
"""

from __future__ import annotations

from typing import Any

import numpy as np

# the fixed bins (the same for every trial, so that counts add up across seeds)
from box2d_driving.metrics.figure_counts import CLOSING_BINS, GAP_BINS, LANE_BINS, PEDESTRIAN_BINS
from box2d_driving.scenarios import scenario

__all__ = ["CLOSING_BINS", "GAP_BINS", "LANE_BINS", "PEDESTRIAN_BINS", "figure_data", "to_majority_side"]


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


def figure_data(env_id: str, table: dict[str, np.ndarray], config: Any) -> dict[str, Any]:
    """Histogram counts for the scenario's figure (its record's ``figure_data``: lane positions
    inside the junction for lanes, distance to the pedestrian ahead at the crosswalk, gap against
    closing speed to the car ahead at real junctions; {} for a scenario that draws none)."""
    return scenario(env_id).figures(table, config)
