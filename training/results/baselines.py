"""Scripted drivers beside the trained policies on the results page: each rule's baselines.

A rule counts as learnt only where the trained policy differs, in the rule's direction, from
drivers that know no rule (full throttle, uniform random; on random paths in the spline
scenarios), scored by the same metric code on the very report episodes its trials were evaluated
on, in their world (car count, message, preset). Each section's ``baseline`` is one of the
functions here (or :func:`scripted_baselines` made for its metrics); its values are keyed
``DRIVER/METRIC`` (``@num_cars=N`` where the section's rows differ in car count).
"""

from __future__ import annotations

import functools
from typing import Any, Callable, Optional

import numpy as np

from training.common.seeds import REPORT
from training.sweeps.spec import PINNED_WORLD
from training.results.data import (Baseline, Group, Metric, ResultsError, as_number, metric_value,
                                   report_episodes)

__all__ = ["RIGHT_OF_WAY_BASELINE_METRICS", "SCRIPTED_BASELINES", "light_blind_rates", "lights_baselines",
           "random_paths", "right_of_way_baselines", "scripted_baselines", "scripted_row", "scripted_table"]


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


def _junction_measures(table: dict[str, Any], cfg: Any) -> dict[str, Any]:
    from box2d_driving.metrics.communication import communication_metrics
    from box2d_driving.metrics.lights import outcome_rates

    return {**outcome_rates(table), **({"communication": communication_metrics(table)} if cfg.communication else {})}


SCRIPTED_MEASURES = {"crosswalk-v0": _crosswalk_measures, "highway-spline-v0": _fast_lane_measures,
                     "intersection-spline-v0": _lane_measures, "real-junction-v0": _junction_measures}


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
        counts = _car_counts(summary)
        return {f"{label}/{metric}" + (f"@num_cars={n}" if len(counts) > 1 else ""):
                (metric_value(scripted_row(env_id, driver, paths, first, episodes, n, overrides), metric), episodes)
                for n in counts for label, driver, paths in drivers for metric in metrics}
    return baseline


def _car_counts(summary: dict[str, Any]) -> list[int]:
    """The cars per instance the finished trials of ``summary`` ran with, each once, ascending."""
    return sorted({int(as_number(r["env_config.num_cars"])) for r in summary["trials"]
                   if r.get("status") == "done" and "env_config.num_cars" in r})


def _one_car_count(summary: dict[str, Any]) -> Optional[int]:
    """The cars per instance every finished trial of ``summary`` ran with, None where they differ."""
    counts = _car_counts(summary)
    return counts[0] if len(counts) == 1 else None


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


# the world settings a lights sweep may fix, as text, that the scripted drivers' world must share
# with its trials: where the cars start, and every setting the paper preset changed after sweeps
# had run with it (training/sweeps/spec.py, PINNED_WORLD: which side they keep to, what an arrived
# car reads, where a car sees its light, how it moves)
WORLD_KEYS = ("approach_order", *PINNED_WORLD)


@functools.lru_cache(maxsize=None)
def scripted_violation_rate(driver: str, num_cars: int, first_seed: int, episodes: int,
                            preset: Optional[str] = None, world: tuple[tuple[str, str], ...] = ()) -> float:
    """The red-light violation rate of a scripted driver that knows no rule (``full-throttle``,
    ``random``) on the given report episodes of ``intersection-v0`` with ``num_cars`` cars, in the
    world of ``preset`` (None: our defaults) with the settings ``world`` (:data:`WORLD_KEYS`)
    over it; LiDAR noise does not matter to either driver: neither reads the LiDAR."""
    from box2d_driving.metrics.lights import traffic_light_metrics

    settings = {**({} if preset is None else {"preset": preset}), **dict(world)}
    table, _ = scripted_table("intersection-v0", driver, first_seed, episodes, num_cars=num_cars, **settings)
    return float(traffic_light_metrics(table)["red_light_violation_rate"])


def lights_baselines(summary: dict[str, Any], groups: list[Group]) -> Baseline:
    """The rule-free scripted drivers' red-light violation rates on the trials' report episodes, in
    the trials' world (their sweep's ``preset``, if any, and the :data:`WORLD_KEYS` it fixes, as a
    sweep from before it recorded them ran: ``saved_fixed``), keyed
    ``DRIVER/red_light_violation_rate`` (a section whose trials share one car count)."""
    from training.sweeps.spec import saved_fixed

    first, episodes = report_episodes(summary)
    n = _one_car_count(summary)
    if n is None:
        return {}
    fixed = saved_fixed(summary["sweep"])
    world = tuple((k, str(fixed[k])) for k in WORLD_KEYS if k in fixed)
    return {f"{driver}/red_light_violation_rate": (scripted_violation_rate(driver, n, first, episodes,
                                                                           fixed.get("preset"), world), episodes)
            for driver in SCRIPTED_BASELINES}
