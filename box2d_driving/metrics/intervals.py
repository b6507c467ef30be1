"""95 % intervals of a policy's rates on one block of episodes, with episodes as clusters.

The cars of one episode share its map, spawns, lights and each other, so their outcomes are not
independent: a pile-up fails several cars at once. Treating every car as an independent draw
(the binomial interval) understates how much a rate moves from one block of episodes to another.
Here the unit of sampling is the episode: a rate is a ratio ``sum of hits / sum of units`` over
episodes, and its standard error is the ratio estimator's, from how much each episode's hits
differ from what the overall rate predicts for its number of units, with the small-sample factor
``G / (G - 1)`` for ``G`` episodes.
"""

from __future__ import annotations

from typing import Optional

import numpy as np

from box2d_driving.metrics.lights import junction_entries, violation_rate
from box2d_driving.metrics.rollouts import COLLIDED_WITH, last_rows

__all__ = ["RATES", "Z95", "clustered_share", "pooled_rate_intervals", "rate_intervals"]

Z95 = 1.959964  # two-sided 95 % normal quantile (hundreds of episodes: t and z agree)


def clustered_share(hits: np.ndarray, clusters: np.ndarray) -> tuple[float, float, float]:
    """Share of ``hits`` (booleans, one per unit: a car, a junction entry) with its standard
    error and 95 % half-width, the units grouped by ``clusters`` (their episode).
    Returns ``(share, standard error, half-width)``; NaNs without units, a zero error with a
    single cluster (nothing to estimate a spread from)."""
    hits = np.asarray(hits, dtype=float)
    clusters = np.asarray(clusters)
    if hits.shape != clusters.shape:
        raise ValueError(f"hits and clusters differ in shape: {hits.shape} vs {clusters.shape}")
    if len(hits) == 0:
        return float("nan"), float("nan"), float("nan")
    _, index = np.unique(clusters, return_inverse=True)
    groups = int(index.max()) + 1
    y = np.bincount(index, weights=hits, minlength=groups)  # hits per episode
    n = np.bincount(index, minlength=groups).astype(float)  # units per episode
    share = float(y.sum() / n.sum())
    if groups < 2:
        return share, 0.0, 0.0
    residual = y - share * n
    se = float(np.sqrt(groups / (groups - 1) * np.sum(residual ** 2)) / n.sum())
    return share, se, Z95 * se


RATES = ("success_rate", "collision_rate", "red_light_violation_rate", "pedestrian_collision_rate")


def rate_intervals(table: dict[str, np.ndarray], names: tuple[str, ...] = RATES[:2]) -> dict[str, dict[str, float]]:
    """``{"value", "se", "half_width"}`` with episodes as clusters for each rate in ``names``:
    success and collisions over cars, red-light violations over junction entries (the report's
    stop value), pedestrian collisions over cars. A rate the table cannot give (no junction
    entries) is left out."""
    return pooled_rate_intervals([table], names)


def pooled_rate_intervals(tables: list[dict[str, np.ndarray]],
                          names: tuple[str, ...] = RATES[:2]) -> dict[str, dict[str, float]]:
    """:func:`rate_intervals` of several policies' rollout tables on the **same** episodes (the
    same ``episode`` numbers, e.g. the trials of a sweep on one block of report episodes), taken
    together: the units of every table pooled, each episode one cluster across the tables. The
    policies share their episodes' luck (an episode that is hard for one is hard for all), so an
    interval over policies alone would miss that; this one counts it. Red-light violations are
    each table's own entries on its own adopted stop value. A rate no table can give is left out."""
    unknown = [n for n in names if n not in RATES]
    if unknown:
        raise ValueError(f"no clustered interval for {', '.join(unknown)}; rates: {', '.join(RATES)}")
    out = {}
    for name in names:
        found = [hits for hits in (_rate_hits(table, name) for table in tables) if hits is not None]
        if found:
            out[name] = _entry(clustered_share(np.concatenate([h for h, _ in found]),
                                               np.concatenate([e for _, e in found])))
    return out


def _rate_hits(table: dict[str, np.ndarray], name: str) -> Optional[tuple[np.ndarray, np.ndarray]]:
    """The units of rate ``name`` in ``table``: (hit per unit, its episode); None if it has none."""
    if name == "red_light_violation_rate":
        return _violations(table)
    idx = last_rows(table)
    episode = table["episode"][idx]
    if name == "success_rate":
        return table["arrived"][idx], episode
    if name == "collision_rate":
        return table["collided"][idx], episode
    return table["collided_with"][idx] == COLLIDED_WITH.index("pedestrian"), episode


def _violations(table: dict[str, np.ndarray]):
    entries = junction_entries(table)
    if not len(entries["light"]):
        return None
    stop = violation_rate(entries["light"]).stop_value
    return np.isclose(entries["light"], stop), entries["episode"]


def _entry(result: tuple[float, float, float]) -> dict[str, float]:
    share, se, half = result
    return {"value": share, "se": se, "half_width": half}
