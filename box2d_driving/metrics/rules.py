"""Each shipped scenario's rule metrics: the few numbers a learning curve follows and a sweep's
summary keeps, from one block of episodes.

Every function takes a rollout table (:mod:`box2d_driving.metrics.rollouts`) and the env's config
and returns its numbers, named as in a sweep's summary (a dot for a nested report entry, e.g.
``right_of_way.fifo_share``). Success and collision rates come first in every curve and are not
repeated here (:data:`OUTCOMES`). A scenario's record (:mod:`box2d_driving.scenarios`) names its
function and the names it always returns. The metric modules are imported on first use, so that
listing the scenarios (``import box2d_driving``) stays cheap.
"""

from __future__ import annotations

from typing import Any

OUTCOMES = ("success_rate", "collision_rate")
VIOLATIONS = ("red_light_violation_rate",)
CROSSWALK = ("pedestrian_collision_rate", "safe_stopping_share", "share_more_than_6m")
JUNCTION = ("right_of_way.fifo_share", "safety_distance.safe_share")
LANES = ("lanes.majority_share", "lanes.time_share_majority", "lanes.mean_abs_lane_position",
         "lanes.one_sided_offset")
FAST_LANES = ("fast_lanes.pearson_r",)
# with the message on, a real junction's curve also follows the communication measures
COMMUNICATION = ("communication.speaker_consistency_bits", "communication.pearson_heading_change_bit")


def outcomes(table: dict, config: Any = None) -> dict[str, float]:
    """Success and collision rates (shares of cars)."""
    from box2d_driving.metrics.lights import outcome_rates

    rates = outcome_rates(table)
    return {k: rates[k] for k in OUTCOMES}


def lights(table: dict, config: Any = None) -> dict[str, float]:
    """The red-light violation rate (signalled junctions)."""
    from box2d_driving.metrics.lights import traffic_light_metrics

    return {"red_light_violation_rate": traffic_light_metrics(table)["red_light_violation_rate"]}


def crosswalk(table: dict, config: Any) -> dict[str, float]:
    """Pedestrian collisions and the shares of samples with room to stop (``config.a_max``)."""
    from box2d_driving.metrics.pedestrians import crosswalk_metrics

    walk = crosswalk_metrics(table, config.a_max)
    return {k: walk[k] for k in CROSSWALK}


def junction_summary(table: dict, config: Any) -> dict[str, float]:
    """Success, collisions, FIFO share and safe-distance share: a real junction's headline numbers
    (the unheard-messages control of its report reads these)."""
    from box2d_driving.metrics.lights import outcome_rates
    from box2d_driving.metrics.right_of_way import fifo_metrics, safety_distance_metrics

    rates = outcome_rates(table)
    return {"success_rate": rates["success_rate"], "collision_rate": rates["collision_rate"],
            "fifo_share": fifo_metrics(table)["fifo_share"],
            "safe_share": safety_distance_metrics(table, config.a_max, config.car_length,
                                                  wrecks_stay=config.wrecks_stay)["safe_share"]}


def real_junction(table: dict, config: Any) -> dict[str, float]:
    """Lights, right of way (FIFO share) and safe following distance; the communication measures
    too where the message is on."""
    summary = junction_summary(table, config)
    out = {**lights(table), "right_of_way.fifo_share": summary["fifo_share"],
           "safety_distance.safe_share": summary["safe_share"]}
    if config.communication:
        from box2d_driving.metrics.communication import communication_metrics

        talk = communication_metrics(table)
        out.update({k: talk[k.split(".", 1)[1]] for k in COMMUNICATION})
    return out


def junction_lanes(table: dict, config: Any = None) -> dict[str, float]:
    """Lights and the side of the road cars cross the junction on (spline junction)."""
    from box2d_driving.metrics.lanes import lane_metrics

    found = lane_metrics(table)
    return {**lights(table), **{k: found[k.split(".", 1)[1]] for k in LANES}}


def fast_lanes(table: dict, config: Any) -> dict[str, float]:
    """The correlation of lateral position with a car's speed rating (``config.road_width``)."""
    from box2d_driving.metrics.lanes import fast_lane_metrics

    return {"fast_lanes.pearson_r": fast_lane_metrics(table, config.road_width)["pearson_r"]}
