"""Reading sweep summaries for the results page: trials grouped by grid point, each metric
estimated over training seeds, each distribution's counts summed over seeds."""

from __future__ import annotations

import functools
import json
from collections import defaultdict
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Optional, Union

import numpy as np

from training.common.seeds import REPORT
from training.evaluation.figure_data import to_majority_side
from training.results.stats import Estimate, mean_ci


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


def scripted_table(env_id: str, driver: str, first_seed: int, episodes: int, paths: str = "axis",
                   **overrides: Any) -> tuple[dict[str, Any], Any]:
    """The rollout table of a scripted driver (``box2d_driving.policies.make_policy`` by name) on
    the given report episodes of ``env_id`` with config ``overrides``, and the env's config;
    :class:`ResultsError` for episodes outside the report range. In a spline scenario ``paths``
    says how each car's path is chosen: ``axis`` (the scenario's default, the road axis) or
    ``random`` (uniform over the path choices, seeded by ``first_seed``)."""
    import box2d_driving
    from box2d_driving.metrics.rollouts import run_episodes
    from box2d_driving.policies import make_policy

    if first_seed not in REPORT or first_seed + episodes - 1 not in REPORT:
        raise ResultsError(f"episodes {first_seed}.. ({episodes}) are not report seeds ({REPORT.describe()})")
    env = box2d_driving.make(env_id, **overrides)
    try:
        if paths == "random":
            env.spline_policy = random_paths(env.spline_action_space, first_seed)
        elif paths != "axis":
            raise ResultsError(f"paths must be 'axis' or 'random', got {paths!r}")
        return run_episodes(env, make_policy(driver, env, seed=first_seed), episodes, seed=first_seed), env.config
    finally:
        env.close()


def random_paths(space: Any, seed: int) -> Any:
    """A stage-0 chooser for a spline scenario: each car's path uniform over ``space`` (a Box of
    continuous path parameters, Discrete or MultiDiscrete), from a generator seeded once with
    ``seed``."""
    from gymnasium import spaces

    rng = np.random.default_rng(seed)

    def choose(obs0: np.ndarray) -> np.ndarray:
        n = len(obs0)
        if isinstance(space, spaces.Box):
            return rng.uniform(space.low, space.high, size=(n,) + space.shape).astype(space.dtype)
        if isinstance(space, spaces.MultiDiscrete):
            return rng.integers(0, space.nvec, size=(n,) + space.shape)
        return rng.integers(0, space.n, size=n)
    return choose


# per scenario, the report measures a scripted driver is scored on (what its report computes
# from the rollouts alone: no control runs), as the nested dict an evaluation writes
def _crosswalk_measures(table: dict[str, Any], cfg: Any) -> dict[str, Any]:
    from box2d_driving.metrics.pedestrians import crosswalk_metrics

    return crosswalk_metrics(table, cfg.a_max)


def _fast_lane_measures(table: dict[str, Any], cfg: Any) -> dict[str, Any]:
    from box2d_driving.metrics.lanes import fast_lane_metrics
    from box2d_driving.metrics.lights import outcome_rates

    return {**outcome_rates(table), "fast_lanes": fast_lane_metrics(table, cfg.road_width)}


def _lane_measures(table: dict[str, Any], cfg: Any) -> dict[str, Any]:
    from box2d_driving.metrics.lanes import lane_metrics
    from box2d_driving.metrics.lights import outcome_rates

    return {**outcome_rates(table), "lanes": lane_metrics(table)}


SCRIPTED_MEASURES = {"crosswalk-v0": _crosswalk_measures, "highway-spline-v0": _fast_lane_measures,
                     "intersection-spline-v0": _lane_measures}


def _junction_measures(table: dict[str, Any], cfg: Any) -> dict[str, Any]:
    from box2d_driving.metrics.communication import communication_metrics
    from box2d_driving.metrics.lights import outcome_rates

    return {**outcome_rates(table), **({"communication": communication_metrics(table)} if cfg.communication else {})}


SCRIPTED_MEASURES["real-junction-v0"] = _junction_measures


@functools.lru_cache(maxsize=None)
def scripted_row(env_id: str, driver: str, paths: str, first_seed: int, episodes: int,
                 num_cars: int, overrides: tuple[tuple[str, Any], ...] = ()) -> dict[str, Any]:
    """A scripted driver's report measures on the given report episodes of ``env_id`` with
    ``num_cars`` cars and config ``overrides`` (its other defaults), flattened like a summary row's
    columns (``a.b``), so that any of a section's metrics (a column, its size, a difference) reads
    from it."""
    from training.sweeps.summary import flatten

    table, cfg = scripted_table(env_id, driver, first_seed, episodes, paths=paths, num_cars=num_cars,
                                **dict(overrides))
    return flatten(SCRIPTED_MEASURES[env_id](table, cfg))


def scripted_baselines(env_id: str, metrics: tuple[Metric, ...], drivers: tuple[tuple[str, str, str], ...],
                       overrides: tuple[tuple[str, Any], ...] = ()
                       ) -> Callable[[dict[str, Any], list[Group]], Baseline]:
    """A section's baseline: each of ``drivers`` (label, scripted driver, path choice) scored on
    ``metrics`` over the trials' report episodes (``env_id`` with config ``overrides``), keyed
    ``LABEL/METRIC`` where every trial has one car count, else ``LABEL/METRIC@num_cars=N`` for each
    count its trials ran."""
    def baseline(summary: dict[str, Any], groups: list[Group]) -> Baseline:
        first, episodes = report_episodes(summary)
        counts = sorted({int(as_number(r["env_config.num_cars"])) for r in summary["trials"]
                         if r.get("status") == "done" and "env_config.num_cars" in r})
        return {f"{label}/{metric}" + (f"@num_cars={n}" if len(counts) > 1 else ""):
                (metric_value(scripted_row(env_id, driver, paths, first, episodes, n, overrides), metric), episodes)
                for n in counts for label, driver, paths in drivers for metric in metrics}
    return baseline


def _one_car_count(summary: dict[str, Any]) -> Optional[int]:
    """The cars per instance every finished trial of ``summary`` ran with, None where they differ."""
    cars = {int(as_number(r["env_config.num_cars"])) for r in summary["trials"]
            if r.get("status") == "done" and "env_config.num_cars" in r}
    return cars.pop() if len(cars) == 1 else None


@functools.lru_cache(maxsize=None)
def light_blind_violation_rate(num_cars: int, lidar_noise: float, first_seed: int, episodes: int) -> float:
    """The red-light violation rate of a light-blind driver (every car at full throttle) on the
    given report episodes of ``intersection-v0``: what a policy that ignores the light scores on
    the very episodes a trial was evaluated on. Scripted, so no checkpoint is needed."""
    from box2d_driving.metrics.lights import traffic_light_metrics

    table, _ = scripted_table("intersection-v0", "full-throttle", first_seed, episodes, num_cars=num_cars,
                              lidar_noise=lidar_noise)
    return float(traffic_light_metrics(table)["red_light_violation_rate"])


def light_blind_rates(summary: dict[str, Any], groups: list[Group]) -> Baseline:
    """Per noise level with a 1-car grid point: the light-blind driver's violation rate on the
    trials' report episodes, and its number of junction entries (1 car: one per episode)."""
    first, episodes = report_episodes(summary)
    return {g.point["lidar_noise"]: (light_blind_violation_rate(1, as_number(g.point["lidar_noise"]), first, episodes),
                                     episodes)
            for g in groups if as_number(g.point.get("num_cars")) == 1.0 and "lidar_noise" in g.point}


# how a sweep without a grid (one setting for every trial) names its one point in lines and figures
SINGLE_POINT = "the sweep's one setting"
# the scripted drivers every rule metric is set beside (same report episodes, same env settings)
SCRIPTED_BASELINES = ("full-throttle", "random")
# the right-of-way measures a scripted driver is scored on
RIGHT_OF_WAY_BASELINE_METRICS = ("right_of_way.fifo_share", "right_of_way.fifo_share_leaving",
                                 "safety_distance.safe_share", "safety_distance.safe_share_moving_leader")


@functools.lru_cache(maxsize=None)
def scripted_junction_metrics(driver: str, num_cars: int, first_seed: int,
                              episodes: int) -> tuple[tuple[str, float], ...]:
    """The right-of-way measures (:data:`RIGHT_OF_WAY_BASELINE_METRICS`) of a scripted driver
    (``full-throttle``: light-blind, every car at full throttle; ``random``: uniform actions) on the
    given report episodes of ``real-junction-v0`` with ``num_cars`` cars and its other defaults."""
    from box2d_driving.metrics.right_of_way import fifo_metrics, leader_samples, safety_distance_from_samples

    table, cfg = scripted_table("real-junction-v0", driver, first_seed, episodes, num_cars=num_cars)
    fifo = fifo_metrics(table)
    safe = safety_distance_from_samples(leader_samples(table, cfg.car_length, wrecks_stay=cfg.wrecks_stay),
                                        cfg.a_max)
    values = {"right_of_way.fifo_share": fifo["fifo_share"],
              "right_of_way.fifo_share_leaving": fifo["fifo_share_leaving"],
              "safety_distance.safe_share": safe["safe_share"],
              "safety_distance.safe_share_moving_leader": safe["safe_share_moving_leader"]}
    return tuple((k, float(values[k])) for k in RIGHT_OF_WAY_BASELINE_METRICS)


def right_of_way_baselines(summary: dict[str, Any], groups: list[Group]) -> Baseline:
    """The scripted drivers' right-of-way measures on the trials' report episodes, keyed
    ``DRIVER/METRIC`` (the count: the report episodes)."""
    first, episodes = report_episodes(summary)
    n = _one_car_count(summary)
    if n is None:
        return {}
    return {f"{driver}/{metric}": (value, episodes) for driver in SCRIPTED_BASELINES
            for metric, value in scripted_junction_metrics(driver, n, first, episodes)}


@functools.lru_cache(maxsize=None)
def scripted_violation_rate(driver: str, num_cars: int, first_seed: int, episodes: int,
                            preset: Optional[str] = None) -> float:
    """The red-light violation rate of a scripted driver that knows no rule (``full-throttle``,
    ``random``) on the given report episodes of ``intersection-v0`` with ``num_cars`` cars, in the
    world of ``preset`` (None: our defaults; LiDAR noise does not matter to either driver: neither
    reads the LiDAR)."""
    from box2d_driving.metrics.lights import traffic_light_metrics

    world = {} if preset is None else {"preset": preset}
    table, _ = scripted_table("intersection-v0", driver, first_seed, episodes, num_cars=num_cars, **world)
    return float(traffic_light_metrics(table)["red_light_violation_rate"])


def lights_baselines(summary: dict[str, Any], groups: list[Group]) -> Baseline:
    """The rule-free scripted drivers' red-light violation rates on the trials' report episodes, in
    the trials' world (their sweep's ``preset``, if any), keyed ``DRIVER/red_light_violation_rate``
    (a section whose trials share one car count)."""
    first, episodes = report_episodes(summary)
    n = _one_car_count(summary)
    if n is None:
        return {}
    preset = summary["sweep"].get("fixed", {}).get("preset")
    return {f"{driver}/red_light_violation_rate": (scripted_violation_rate(driver, n, first, episodes, preset),
                                                   episodes)
            for driver in SCRIPTED_BASELINES}
