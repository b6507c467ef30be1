"""Per-scenario evaluation reports: metrics dict + plots written into an output folder.

A report gets the rollout table, the env and policy evaluated, the output folder, the episode
count and first seed, and ``make_env(**overrides)`` for control runs with the same settings."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Callable

import numpy as np

from box2d_driving.metrics.collisions import collision_breakdown, wreck_collision_room
from box2d_driving.metrics.lanes import fast_lane_metrics, junction_lane_samples, lane_metrics
from box2d_driving.metrics.lights import GO_STOP, junction_entries, outcome_rates, traffic_light_metrics
from box2d_driving.metrics.pedestrians import crosswalk_metrics, pedestrian_samples
from box2d_driving.metrics.right_of_way import (closing_samples, fifo_metrics, leader_samples,
                                                 safety_distance_from_samples, unsafe_breakdown)
from box2d_driving.metrics.rollouts import last_rows, run_episodes
from box2d_driving.metrics.rules import junction_summary
from box2d_driving.scenarios import scenario
from training.evaluation import plots


def add_collisions(metrics: dict, table: dict, out: Path) -> dict:
    """Part of every report: what each collided car hit and where (``metrics["collisions"]``,
    ``collisions.png``)."""
    metrics["collisions"] = collision_breakdown(table)
    plots.collision_kinds(metrics["collisions"], out / "collisions.png", len(last_rows(table)))
    return metrics


def lights_report(table: dict, env: Any, policy: Any, out: Path, episodes: int, seed: int,
                  make_env: Callable[..., Any]) -> dict:
    """Traffic-light measures (which light value the cars stop at, violations, whether a violator
    could have stopped) and their plots."""
    # the hardest braking a car has: whether a car that entered on the stop value could have stopped
    metrics = traffic_light_metrics(table, max_brake=-min(env.config.accelerations))
    plots.acceleration_by_light(table, out / "acceleration_by_light.png", metrics["stop_value"])
    go = GO_STOP[1] if metrics["stop_value"] == GO_STOP[0] else GO_STOP[0]
    plots.junction_light_histogram(table, junction_entries(table), go, out / "junction_light.png")
    return metrics


def crosswalk_report(table: dict, env: Any, policy: Any, out: Path, episodes: int, seed: int,
                     make_env: Callable[..., Any]) -> dict:
    """Pedestrian measures (the share of samples with room to stop before the nearest pedestrian
    ahead, pedestrian collisions, speed against distance) and their plots, with the same policy's
    episodes with pedestrians unseen as the control where it sees through LiDAR."""
    a_max = env.config.a_max
    metrics = crosswalk_metrics(table, a_max)
    s, control = pedestrian_samples(table), None
    # control: the same policy and settings with pedestrians invisible to the LiDAR (still solid);
    # meaningless for a privileged policy, which does not look through the LiDAR
    if not getattr(policy, "privileged", False):
        blind = run_episodes(make_env(lidar_sees_pedestrians=False), policy, episodes, seed=seed)
        blind_metrics = crosswalk_metrics(blind, a_max)
        metrics["invisible_pedestrians"] = {k: blind_metrics[k] for k in (
            "pedestrian_collision_rate", "collision_rate", "success_rate", "safe_stopping_share")}
        control = pedestrian_samples(blind)["distance"]
    plots.pedestrian_distance_kde(s["distance"], out / "pedestrian_distance.png", control)
    plots.speed_vs_distance(s["distance"], s["speed"], a_max, out / "speed_vs_pedestrian_distance.png")
    cw = np.isfinite(table["crosswalk_distance"]) & (table["decision"] > 0)
    plots.speed_vs_distance(np.clip(table["crosswalk_distance"][cw], 0, None), table["speed"][cw],
                            a_max, out / "speed_vs_crosswalk_distance.png",
                            xlabel="distance from the car's front to the crosswalk (m)")
    return metrics


def lanes_report(table: dict, env: Any, policy: Any, out: Path, episodes: int, seed: int,
                 make_env: Callable[..., Any]) -> dict:
    """The traffic-light report plus lane measures (which side of the road cars cross the junction
    on, and how far off the axis) and the lane-position histogram."""
    metrics = lights_report(table, env, policy, out, episodes, seed, make_env)
    metrics["lanes"] = lane_metrics(table)
    plots.lane_histogram({"policy": junction_lane_samples(table)}, out / "lane_histogram.png")
    return metrics


def fast_lanes_report(table: dict, env: Any, policy: Any, out: Path, episodes: int, seed: int,
                      make_env: Callable[..., Any]) -> dict:
    """Outcomes and fast-lane measures (lateral position against a car's speed rating) and their
    plot."""
    metrics: dict[str, Any] = outcome_rates(table)
    metrics["fast_lanes"] = fast_lane_metrics(table, env.config.road_width)
    plots.lateral_over_time(table, env.config.road_width, out / "lateral_by_rating.png")
    return metrics


def real_junction_report(table: dict, env: Any, policy: Any, out: Path, episodes: int, seed: int,
                         make_env: Callable[..., Any]) -> dict:
    """Outcomes, lights, right of way (FIFO), safe following distance (+ scatter), and the
    communication metrics when the bit is on."""
    cfg = env.config
    metrics = lights_report(table, env, policy, out, episodes, seed, make_env)
    metrics["right_of_way"] = fifo_metrics(table)
    s = leader_samples(table, cfg.car_length, wrecks_stay=cfg.wrecks_stay)
    metrics["safety_distance"] = safety_distance_from_samples(s, cfg.a_max)
    metrics["safety_distance"]["unsafe"] = unsafe_breakdown(table, s, cfg.a_max, cfg.car_length)
    c = closing_samples(s, cfg.a_max)
    plots.speed_vs_distance(c["gap"], c["closing_speed"], cfg.a_max,
                            out / "safety_distance.png", xlabel="gap to the car ahead (m)",
                            ylabel="closing speed (m/s)", marked=c["leader_halted"],
                            marked_label="car ahead is a wreck")
    if cfg.wrecks_stay:  # pile-ups: could the cars that hit a wreck have braked in time?
        metrics["wreck_collisions"] = wreck_collision_room(table, cfg.a_max, cfg.car_length)
    if cfg.communication:
        from box2d_driving.metrics.communication import communication_metrics

        metrics["communication"] = communication_metrics(table)
        # control: the same policy with the bits sent but never heard (everyone receives 0)
        deaf = run_episodes(make_env(messages_heard=False), policy, episodes, seed=seed)
        metrics["messages_unheard"] = junction_summary(deaf, cfg)
    return metrics


def report_for(env_id: str) -> Callable[..., dict]:
    """The evaluation report of ``env_id``: its scenario record's ``report``; for a scenario
    without one, success, collisions and the record's rule metrics
    (:meth:`box2d_driving.scenarios.Scenario.measure`)."""
    record = scenario(env_id)
    if record.report is not None:
        return record.resolve("report")

    def rule_report(table: dict, env: Any, policy: Any, out: Path, episodes: int, seed: int,
                    make_env: Callable[..., Any]) -> dict:
        return {**outcome_rates(table), **record.measure(table, env.config)}

    return rule_report
