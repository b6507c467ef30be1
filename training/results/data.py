"""Reading sweep summaries for the results page: trials grouped by grid point, each metric
estimated over training seeds, each distribution's counts summed over seeds."""

from __future__ import annotations

import json
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Optional, Union

import numpy as np

from training.common.seeds import REPORT
from training.sweeps.spec import saved_fixed
from training.evaluation.figure_data import to_majority_side
from box2d_driving.metrics.stats import Estimate, mean_ci


# below this mean success rate a grid point's policy has not learnt the task at the sweep's budget
LEARNT_SUCCESS = 0.5


# per grid value (a LiDAR noise level), a scripted reference driver's rate on a trial's report
# episodes and the number of events it was measured on (its binomial margin follows from both)
Baseline = dict[str, tuple[float, int]]


@dataclass(frozen=True)
class Size:
    """The size of a summary column (or of another metric): a measure whose sign is arbitrary per
    run (a correlation with a bit whose meaning each run picks, the side lanes settle on) is
    averaged over seeds by size."""

    column: "Metric"

    def __str__(self) -> str:
        return f"|{self.column}|"


@dataclass(frozen=True)
class Difference:
    """``first`` minus ``second`` of the same trial: an ablation measured on the same episodes.
    The difference is taken per trial, then estimated over seeds, so seed-to-seed spread common
    to both cancels."""

    first: "Metric"
    second: "Metric"

    def __str__(self) -> str:
        return f"{self.first} - {self.second}"


# a summary column by name, its size, or the difference of two metrics
@dataclass(frozen=True)
class HistogramMean:
    """The mean of one of a trial's stored distributions (``figures[name]``, counts in ``bins``),
    read at the bin centres: e.g. the signed mean lane position in the junction."""

    name: str
    bins: tuple[float, ...]

    def __str__(self) -> str:
        return f"mean of {self.name}"


@dataclass(frozen=True)
class Preferred:
    """A trial's own summary column where it has one, else ``fallback`` (older summaries, written
    before the column existed): e.g. the one-sided lane offset from the lane samples, else from
    the lane histogram's bin centres."""

    column: str
    fallback: "Metric"

    def __str__(self) -> str:
        return self.column


Metric = Union[str, Size, Difference, HistogramMean, Preferred]


def metric_bounds(metric: "Metric") -> Optional[tuple[float, float]]:
    """The range a metric's values can take, where its name tells: shares and rates (a success,
    a collision, a violation, a FIFO or safe-distance share, a majority share) [0, 1]; the size of
    a value in [-1, 1] or of a lane offset [0, 1]; a correlation [-1, 1]; mutual information in
    bits [0, 1] (one bit sent); a difference of two bounded metrics, what their ranges allow. None:
    unbounded or unknown (a mean time)."""
    if isinstance(metric, Size):
        inner = metric_bounds(metric.column)
        return None if inner is None else (0.0, max(abs(inner[0]), abs(inner[1])))
    if isinstance(metric, Preferred):
        return metric_bounds(metric.column)
    if isinstance(metric, Difference):
        a, b = metric_bounds(metric.first), metric_bounds(metric.second)
        return None if a is None or b is None else (a[0] - b[1], a[1] - b[0])
    if not isinstance(metric, str):
        return None
    name = metric.lower()
    if "abs_lane_position" in name:
        return (0.0, 1.0)
    if "pearson" in name or "lane_position" in name or "offset" in name:
        return (-1.0, 1.0)
    if name.endswith("_bits"):
        return (0.0, 1.0)
    if name.endswith(("_rate", "_share", "majority")) or "_share_" in name or name.endswith("share_moving_leader"):
        return (0.0, 1.0)
    return None


@dataclass(frozen=True)
class PaperValue:
    """A number the paper reports for a metric: value and, where given, its +- spread."""

    metric: Metric
    value: float
    spread: Optional[float] = None
    text: str = ""


class ResultsError(ValueError):
    """A summary that cannot go on the results page."""


@dataclass
class Group:
    """The trials of one grid point: its settings, per metric the estimate over seeds, and each
    distribution's counts summed over seeds (``figures``; lane positions mirrored per seed to its
    own majority side first, see :func:`training.evaluation.figure_data.to_majority_side`)."""

    point: dict[str, str]
    seeds: list[int]
    estimates: dict[Metric, Estimate]
    figures: dict[str, Any] = field(default_factory=dict)


# -- reading ----------------------------------------------------------------------------------
def load_summary(path: Path) -> dict[str, Any]:
    """A sweep's ``summary.json``; :class:`ResultsError` if unreadable or not on report seeds."""
    try:
        data = json.loads(Path(path).read_text())
        sweep, trials = data["sweep"], data["trials"]
        grid = dict(sweep["grid"])
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise ResultsError(f"{path}: not a sweep summary ({exc})") from None
    for row in trials:
        if row.get("status") != "done":
            continue
        first, n = row.get("report_first_seed"), row.get("report_episodes")
        if not isinstance(first, int) or not isinstance(n, int) or first not in REPORT or first + n - 1 not in REPORT:
            raise ResultsError(f"{path}: trial {row.get('trial')} was evaluated on episodes {first}.. "
                               f"({n} of them), not on report seeds ({REPORT.describe()})")
    # a sweep from before the LiDAR encoder was recorded ran with the one its time built
    sweep = {**sweep, "fixed": saved_fixed(sweep)}
    return {"path": str(path), "sweep": sweep, "grid": grid, "trials": trials}


def groups_of(summary: dict[str, Any], metrics: list[Metric]) -> list[Group]:
    """Finished trials grouped by grid point, in grid order, each metric estimated over seeds."""
    by_point: dict[tuple, list[dict]] = defaultdict(list)
    keys = list(summary["grid"])
    for row in summary["trials"]:
        if row.get("status") == "done":
            by_point[tuple(str(row[k]) for k in keys)].append(row)
    order = {tuple(v): i for i, v in enumerate(grid_product([summary["grid"][k] for k in keys]))}
    groups = []
    for values in sorted(by_point, key=lambda v: order.get(v, len(order))):
        rows = sorted(by_point[values], key=lambda r: r["seed"])
        figures: dict[str, Any] = {}
        for r in rows:
            for name, counts in (r.get("figures") or {}).items():
                counts = to_majority_side(name, counts)  # a side each seed picks is not pooled away
                figures[name] = figures[name] + counts if name in figures else counts
        groups.append(Group(dict(zip(keys, values)), [r["seed"] for r in rows],
                            {m: mean_ci((metric_value(r, m) for r in rows), metric_bounds(m)) for m in metrics},
                            figures))
    return groups


def metric_value(row: dict[str, Any], metric: Metric) -> float:
    """A trial's value of ``metric`` (NaN where a column is missing or not a number)."""
    if isinstance(metric, Difference):
        return metric_value(row, metric.first) - metric_value(row, metric.second)
    if isinstance(metric, Size):
        return abs(metric_value(row, metric.column))
    if isinstance(metric, Preferred):
        value = as_number(row.get(metric.column))
        return value if np.isfinite(value) else metric_value(row, metric.fallback)
    if isinstance(metric, HistogramMean):
        counts = (row.get("figures") or {}).get(metric.name)
        if counts is None or np.sum(counts) <= 0:
            return float("nan")
        bins = np.asarray(metric.bins, dtype=float)
        return float(np.dot(np.asarray(counts, dtype=float), (bins[:-1] + bins[1:]) / 2) / np.sum(counts))
    return as_number(row.get(metric))


def grid_product(lists: list[list[str]]) -> list[list[str]]:
    out: list[list[str]] = [[]]
    for values in lists:
        out = [prefix + [v] for prefix in out for v in values]
    return out


def as_number(value: Any) -> float:
    try:
        return float(value)
    except (TypeError, ValueError):
        return float("nan")


def report_episodes(summary: dict[str, Any]) -> tuple[int, int]:
    """(first seed, count) of the report episodes every finished trial of ``summary`` was
    evaluated on; :class:`ResultsError` if they differ between trials."""
    sets = {(r["report_first_seed"], r["report_episodes"]) for r in summary["trials"] if r.get("status") == "done"}
    if len(sets) != 1:
        raise ResultsError(f"{summary['path']}: trials were evaluated on different report episodes ({sorted(sets)})")
    return next(iter(sets))


# how a sweep without a grid (one setting for every trial) names its one point in lines and figures
SINGLE_POINT = "the sweep's one setting"
