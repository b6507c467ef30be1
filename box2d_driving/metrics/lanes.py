"""Lane metrics (lanes at a junction, fast lanes on a highway) from rollout tables.

Lanes: the normalised lane position is the ``lane_offset`` column (signed offset from the road
axis / (W/2), + = right of the direction of travel). A *crossing* is one car's pass through the
junction box; its side is the sign of its mean lane position while inside the box (0 counts as
neither side).

Fast lanes: a car's lateral position is ``2 y / W`` (+ = left, +y) at its last recorded decision
(where its chosen lane has been reached, unless it crashed on the way); correlated with its
acceleration rating over all cars of all episodes.
"""

from __future__ import annotations

import numpy as np

from box2d_driving.metrics.rollouts import last_rows


def junction_lane_samples(table: dict[str, np.ndarray]) -> np.ndarray:
    """Normalised lane positions of every car inside the junction box, every decision."""
    inside = table["in_junction"] & np.isfinite(table["lane_offset"])
    return table["lane_offset"][inside]


def crossing_sides(table: dict[str, np.ndarray]) -> np.ndarray:
    """Mean normalised lane position of each crossing (one per car and episode that entered the
    junction)."""
    inside = table["in_junction"] & np.isfinite(table["lane_offset"])
    if not inside.any():
        return np.zeros(0)
    key = table["episode"][inside].astype(np.int64) * (int(table["car"].max()) + 1) + table["car"][inside]
    _, group = np.unique(key, return_inverse=True)
    sums = np.bincount(group, weights=table["lane_offset"][inside])
    return sums / np.bincount(group)


def lane_metrics(table: dict[str, np.ndarray], bins: int = 20) -> dict:
    """Majority side, share of crossings and of in-junction time on it, how far off the axis the
    cars drive (``mean_abs_lane_position`` on either side; ``one_sided_offset``, the size of the
    mean signed position: ~0 on the axis or on both sides in turn, the offset when every car keeps
    to one side), and the histogram of normalised lane position through the junction (``bins``
    over ``[-1, 1]``)."""
    sides = crossing_sides(table)
    samples = junction_lane_samples(table)
    right, left = int(np.sum(sides > 0)), int(np.sum(sides < 0))
    majority = "right" if right >= left else "left"
    sign = 1.0 if majority == "right" else -1.0
    counts, edges = np.histogram(np.clip(samples, -1, 1), bins=bins, range=(-1.0, 1.0))
    return {
        "crossings": int(len(sides)),
        "crossings_right": right,
        "crossings_left": left,
        "majority_side": majority,
        "majority_share": float(max(right, left) / len(sides)) if len(sides) else float("nan"),
        "time_share_majority": float(np.mean(samples * sign > 0)) if len(samples) else float("nan"),
        "mean_abs_lane_position": float(np.mean(np.abs(samples))) if len(samples) else float("nan"),
        "one_sided_offset": float(abs(np.mean(samples))) if len(samples) else float("nan"),
        "histogram": counts.tolist(),
        "bin_edges": edges.tolist(),
    }


def final_lateral_positions(table: dict[str, np.ndarray], road_width: float) -> tuple[np.ndarray, np.ndarray]:
    """Each car's rating and ``2 y / W`` at its last recorded decision (one entry per car and
    episode)."""
    idx = last_rows(table)
    return table["rating"][idx].astype(float), 2.0 * table["y"][idx] / road_width


def pearson(a: np.ndarray, b: np.ndarray) -> float:
    """Pearson correlation; NaN when either input is constant or has fewer than 2 entries."""
    a, b = np.asarray(a, float), np.asarray(b, float)
    if len(a) < 2 or a.std() == 0 or b.std() == 0:
        return float("nan")
    return float(np.corrcoef(a, b)[0, 1])


def fast_lane_metrics(table: dict[str, np.ndarray], road_width: float) -> dict:
    """Pearson(rating, lateral position) and the lane split by rating: mean lateral position of
    the faster and the slower half of the cars (split at the median rating)."""
    rating, lateral = final_lateral_positions(table, road_width)
    if len(rating) == 0:
        return {"cars": 0, "pearson_r": float("nan")}
    fast = rating >= np.median(rating)
    return {
        "cars": int(len(rating)),
        "pearson_r": pearson(rating, lateral),
        "fast_half_mean_lateral": float(lateral[fast].mean()),
        "slow_half_mean_lateral": float(lateral[~fast].mean()) if (~fast).any() else float("nan"),
        "fast_side": "left" if lateral[fast].mean() > lateral[~fast].mean() else "right",
    }
