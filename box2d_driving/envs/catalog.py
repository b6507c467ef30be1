"""The scenarios this package ships, as records (:mod:`box2d_driving.scenarios`).

:mod:`box2d_driving.scenarios` registers them first. Classes and functions are named as
``"module:name"`` so that listing the ids imports no env.
"""

from __future__ import annotations

from box2d_driving.metrics import rules
from box2d_driving.scenario import Scenario, SingleAgent

_REPORTS = "training.evaluation.reports"  # the full reports (plots) live with the trainers
_JUNCTION_DRIVERS = ("random", "full-throttle", "rule")

SHIPPED = (
    Scenario("intersection-v0", "box2d_driving.envs.intersection:IntersectionEnv",
             "signalled four-way junction, fixed straight tracks (traffic lights)",
             rule_metrics=rules.lights, curve_metrics=rules.VIOLATIONS, report=f"{_REPORTS}:lights_report",
             baselines=_JUNCTION_DRIVERS,
             single_agent=SingleAgent("box2d_driving/Intersection-v0", "traffic_lights_4cars_noise05", "rule"),
             trainer="lights"),
    Scenario("highway-v0", "box2d_driving.envs.highway:HighwayEnv",
             "one-way highway, cars of different acceleration ratings (safe distance)",
             single_agent=SingleAgent("box2d_driving/Highway-v0", None, "full-throttle")),
    Scenario("crosswalk-v0", "box2d_driving.envs.crosswalk:CrosswalkEnv",
             "highway with a crosswalk and crossing pedestrians (slow down for pedestrians)",
             rule_metrics=rules.crosswalk, curve_metrics=rules.CROSSWALK,
             figure_data="box2d_driving.metrics.figure_counts:pedestrian_distances",
             report=f"{_REPORTS}:crosswalk_report", baselines=("random", "full-throttle", "pedestrian-oracle"),
             single_agent=SingleAgent("box2d_driving/Crosswalk-v0", "crosswalk_4cars_satnav_collision6",
                                      "pedestrian-oracle"),
             trainer="crosswalk"),
    Scenario("intersection-spline-v0", "box2d_driving.envs.intersection_spline:IntersectionSplineEnv",
             "signalled junction; each car picks its own spline path first (lanes emerge)",
             rule_metrics=rules.junction_lanes, curve_metrics=rules.VIOLATIONS + rules.LANES,
             figure_data="box2d_driving.metrics.figure_counts:lane_positions", report=f"{_REPORTS}:lanes_report",
             baselines=_JUNCTION_DRIVERS, trainer="lanes"),
    Scenario("highway-spline-v0", "box2d_driving.envs.highway_spline:HighwaySplineEnv",
             "one-way highway; each car picks its own lateral target first (fast lanes emerge)",
             rule_metrics=rules.fast_lanes, curve_metrics=rules.FAST_LANES, report=f"{_REPORTS}:fast_lanes_report",
             trainer="fast-lanes"),
    Scenario("real-junction-v0", "box2d_driving.envs.real_junction:RealJunctionEnv",
             "real junctions from OpenStreetMap: lanes, turns, real signals (right of way)",
             rule_metrics=rules.real_junction, curve_metrics=rules.VIOLATIONS + rules.JUNCTION,
             figure_data="box2d_driving.metrics.figure_counts:gaps_and_closing_speeds",
             report=f"{_REPORTS}:real_junction_report", baselines=_JUNCTION_DRIVERS,
             single_agent=SingleAgent("box2d_driving/RealJunction-v0", "real_junction_8cars_collision3", "rule"),
             trainer="real-junction"),
)
