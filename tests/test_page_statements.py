"""The results page's numbers and words: measures, intervals, tests, and each statement it prints,
on hand-built trials."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest

from tests.results_helpers import VIOLATIONS, lights_summary, ragged_tables
from training.common.seeds import REPORT
from training.results.reproduce import Group, main
from box2d_driving.metrics.stats import mean_ci, t95, t_test_p


def test_a_metric_is_a_column_its_size_or_the_difference_of_two_metrics():
    from training.results.data import Difference, Size, metric_value

    row = {"a": 0.8, "b": 0.65, "r": -0.3, "text": "x", "c - d": 0.5, "abs:a": 2.0}
    assert metric_value(row, "a") == 0.8 and metric_value(row, Size("r")) == 0.3
    assert metric_value(row, Difference("a", "b")) == pytest.approx(0.15)
    assert metric_value(row, Difference("b", Size("r"))) == pytest.approx(0.35)
    assert math.isnan(metric_value(row, Difference("a", "missing"))) and math.isnan(metric_value(row, "text"))
    # a column is read by its name whatever characters it holds
    assert metric_value(row, "c - d") == 0.5 and metric_value(row, "abs:a") == 2.0
    assert str(Difference("a", Size("r"))) == "a - |r|"


def test_mean_and_interval_match_a_hand_computation():
    e = mean_ci([0.10, 0.12, 0.08])
    sd = math.sqrt(((0.0) ** 2 + 0.02 ** 2 + 0.02 ** 2) / 2)
    assert e.mean == pytest.approx(0.10) and e.high - e.mean == pytest.approx(4.302653 * sd / math.sqrt(3))
    assert mean_ci([0.3]).low is None and mean_ci([]).n == 0 and mean_ci([1.0, float("nan")]).n == 1
    assert e.interval == (e.low, e.high)  # what the verdicts compare; none from fewer than two values
    with pytest.raises(ValueError, match="no interval from 1 value"):
        mean_ci([0.3]).interval
    # the exact quantiles, not a table's rounded ones (nor the next tabulated one between rows)
    assert t95(2) == pytest.approx(4.302653, abs=1e-6) and t95(22) == pytest.approx(2.073873, abs=1e-6)
    assert t95(1000) == pytest.approx(1.962339, abs=1e-6) and t95(22) < t95(20)


def test_the_paper_comparison_says_inside_or_outside(tmp_path):
    from training.results.reproduce import SECTIONS, Group
    from training.results.statements import paper_comparison

    section = next(s for s in SECTIONS if s.key == "right-of-way")
    groups = [Group({}, [0, 1, 2], {"right_of_way.fifo_share": mean_ci([0.90, 0.91, 0.92]),
                                    "safety_distance.safe_share": mean_ci([0.95, 0.96, 0.94])})]
    lines = "\n".join(paper_comparison(section.paper_values, groups))
    # the paper's +- 8.9 is a spread over its runs: our mean is compared with it, not called an interval
    assert "not a confidence interval): our mean is inside that spread" in lines  # 0.91 within 0.8525 +- 0.089
    assert "the paper's value lies outside our interval" in lines  # 0.9845 vs 0.95 +- 0.025
    p = t_test_p([0.95, 0.96, 0.94], 0.9845)
    assert f"all 3 seeds below it; one-sample t-test p = {p:.3f}" in lines
    mixed = [Group({}, [0, 1, 2], {"right_of_way.fifo_share": mean_ci([0.9] * 3),
                                   "safety_distance.safe_share": mean_ci([0.97, 0.99, 0.995])})]
    text = "\n".join(paper_comparison(section.paper_values, mixed))
    assert "1 of 3 seeds below it, 2 above" in text
    two = [Group({}, [0, 1], {"right_of_way.fifo_share": mean_ci([0.9] * 2),
                              "safety_distance.safe_share": mean_ci([0.95, 0.96])})]
    assert "both seeds below it; one-sample t-test" in "\n".join(paper_comparison(section.paper_values, two))
    # inside the interval: how many seeds this spread would need (differences -0.0145, 0.0055, 0.0105
    # from 0.9845: a mean of 0.0002 against an sd of 0.013, beyond any sweep)
    assert "a planning estimate, taking this mean and spread as true: more than 200 seeds would be needed" in text


def test_the_t_test_p_value_meets_the_t_table_and_the_obvious_cases():
    from box2d_driving.metrics.stats import incomplete_beta

    # standard tables' 95 % quantiles (3 decimals) against the exact ones, which give p = 0.05
    table = {1: 12.706, 2: 4.303, 3: 3.182, 4: 2.776, 5: 2.571, 10: 2.228, 20: 2.086, 30: 2.042, 120: 1.980}
    for dof, t in table.items():
        assert abs(t95(dof) - t) < 6e-4
        assert abs(incomplete_beta(dof / 2, 0.5, dof / (dof + t95(dof) ** 2)) - 0.05) < 1e-9
    assert t_test_p([1.0, 2.0, 3.0], 2.0) == pytest.approx(1.0)
    # t = (2 - 0) / (1 / sqrt 3) = 3.464 with 2 dof: p = 0.0742 (tables)
    assert t_test_p([1.0, 2.0, 3.0], 0.0) == pytest.approx(0.0742, abs=5e-4)
    assert t_test_p([0.5], 0.0) is None
    assert t_test_p([0.5, 0.5], 0.0) == 0.0


def test_welch_p_value_and_the_seeds_two_independent_rows_would_need():
    from training.results.statements import (
        apart,
        reference_statement,
        seeds_needed_apart,
    )
    from box2d_driving.metrics.stats import welch_p

    # equal spreads and sizes: Welch's t equals Student's, t = 3 / sqrt(2 / 3) = 3.674 with 4 dof: p = 0.0213
    assert welch_p([1.0, 2.0, 3.0], [4.0, 5.0, 6.0]) == pytest.approx(0.0213, abs=5e-4)
    assert welch_p([4.0, 5.0, 6.0], [1.0, 2.0, 3.0]) == welch_p([1.0, 2.0, 3.0], [4.0, 5.0, 6.0])
    assert welch_p([1.0, 2.0, 3.0], [1.0, 2.0, 3.0]) == pytest.approx(1.0)
    assert welch_p([1.0], [2.0, 3.0]) is None
    assert welch_p([1.0, 1.0], [2.0, 2.0]) == 0.0
    # unequal spreads: fewer degrees of freedom than pooling would give, so a larger p
    assert welch_p([2.0, 2.1, 2.2, 2.3], [0.0, 3.0, 6.0]) > 0.3
    # sd 0.01 in each row, means 0.02 apart: k seeds per row tell once t95(dof) * sqrt(2e-4 / k) < 0.02,
    # with dof = 2 (k - 1): k = 4 (t95(6) = 2.447: 0.0173)
    assert seeds_needed_apart([0.09, 0.10, 0.11], [0.11, 0.12, 0.13]) == \
        "; a planning estimate, taking this difference and spread as true: about 4 seeds per row would tell"
    assert seeds_needed_apart([0.1, 0.2], [0.1, 0.2]) == ""
    more = Group({}, [0, 1, 2], {"red_light_violation_rate": mean_ci([0.118, 0.134, 0.127])})
    four = Group({}, [0, 1, 2], {"red_light_violation_rate": mean_ci([0.076, 0.077, 0.114])})
    line = reference_statement([more], four, "the 4-car row")[0]
    # not detected, with the largest fall the two intervals still allow: 4-car high minus 8-car low
    allow = four.estimates["red_light_violation_rate"].high - more.estimates["red_light_violation_rate"].low
    assert (f"the intervals overlap: no difference detected; they allow a fall of up to {max(0.0, allow):.3f} "
            "(Welch's t-test p = ") in line
    assert f"p = {welch_p([0.118, 0.134, 0.127], [0.076, 0.077, 0.114]):.3f}; a planning estimate" in line
    # overlapping intervals whose difference Welch's test still separates (the 8-car 16 M row against
    # five 4-car seeds): the verdict follows the test and names no seed count
    five = Group({}, [0, 1, 2, 3, 4], {"red_light_violation_rate": mean_ci([0.076, 0.0775, 0.114, 0.076, 0.099])})
    assert apart(five.estimates["red_light_violation_rate"], more.estimates["red_light_violation_rate"]) == 0
    line = reference_statement([more], five, "the 4-car row")[0]
    p = welch_p([0.118, 0.134, 0.127], [0.076, 0.0775, 0.114, 0.076, 0.099])
    assert p < 0.05
    assert line.endswith("more violations with more cars by Welch's test, though the two intervals overlap, "
                         f"unlike the paper (Welch's t-test p = {p:.3f}).")
    apart_ = Group({}, [0, 1, 2], {"red_light_violation_rate": mean_ci([0.01, 0.011, 0.012])})
    line = reference_statement([apart_], four, "the 4-car row")[0]
    assert line.endswith("fewer violations with more cars, intervals apart, as in the paper (Welch's t-test p = "
                         f"{welch_p([0.01, 0.011, 0.012], [0.076, 0.077, 0.114]):.3f}).")


def test_lanes_measures_from_hand_built_trials():
    import numpy as np

    from training.evaluation import figure_data as fd
    from training.results.data import HistogramMean, Size, groups_of, metric_value
    from training.results.reproduce import ran_budget
    from training.results.rule_parts import ONE_SIDED

    bins = fd.LANE_BINS
    left = np.zeros(len(bins) - 1)
    left[3] = 10  # every sample in one bin left of the axis: centre (bins[3] + bins[4]) / 2
    centre = (bins[3] + bins[4]) / 2
    row = {"seed": 0, "status": "done", "num_cars": "8", "decisions": 1_536_000,
           "figures": {"lane_position_counts": left.tolist()}}
    assert metric_value(row, HistogramMean("lane_position_counts", tuple(bins))) == pytest.approx(centre)
    assert metric_value(row, ONE_SIDED) == pytest.approx(-centre)  # the size: |mean| > 0 on one side
    split = dict(row, figures={"lane_position_counts": (left + left[::-1]).tolist()})
    assert metric_value(split, ONE_SIDED) == pytest.approx(0.0, abs=1e-12)  # both sides in turn: 0
    assert np.isnan(metric_value({"figures": {}}, Size(HistogramMean("lane_position_counts", tuple(bins)))))
    # summed over seeds, each seed's histogram is first mirrored to its own majority side
    right = dict(row, seed=1, figures={"lane_position_counts": left[::-1].tolist()})
    summary = {"grid": {"num_cars": ["8"]}, "trials": [row, right]}
    (group,) = groups_of(summary, [ONE_SIDED])
    counts = group.figures["lane_position_counts"]
    assert counts[len(bins) - 2 - 3] == 20 and counts[3] == 0
    assert ran_budget([row, right]) == " (each ran 1,536,000 decisions: whole rollouts)"
    assert ran_budget([row, dict(right, decisions=1_568_000)]) == \
        " (each ran 1,536,000 to 1,568,000 decisions: whole rollouts)"


def test_a_grid_point_whose_cars_do_not_arrive_is_called_unlearnt(tmp_path):
    summary = json.loads(lights_summary(tmp_path / "s.json", VIOLATIONS).read_text())
    for row in summary["trials"]:
        if row["num_cars"] == "4" and row["lidar_noise"] == "0":
            row["success_rate"] = 0.3
    (tmp_path / "s.json").write_text(json.dumps(summary))
    page = tmp_path / "results.md"
    assert main([str(tmp_path / "s.json"), "--out", str(page)]) == 0
    notes = [line for line in page.read_text().splitlines() if "have not learnt" in line]
    assert len(notes) == 1 and notes[0].startswith("- lidar_noise=0, num_cars=4: success 0.300")


def test_a_lone_car_that_stops_on_red_is_told_apart_from_a_light_blind_driver(tmp_path):
    from training.results.baselines import light_blind_violation_rate

    blind = light_blind_violation_rate(1, 0.0, REPORT.start, 200)
    assert 0.3 < blind < 0.6  # full throttle enters on red about as often as on green
    summary = lights_summary(tmp_path / "s.json", {**VIOLATIONS, ("0", "1"): [0.05, 0.06, 0.04]})
    page = tmp_path / "results.md"
    assert main([str(summary), "--out", str(page)]) == 0
    lines = [line for line in page.read_text().splitlines() if line.startswith("- 1 car, red-light violations")]
    # the two noise levels disagree, so each gets its own line and neither claims every level
    assert len(lines) == 2 and not any("every noise level" in line for line in lines)
    assert ": noise 0 0.050" in lines[0] and "the lone car reacts to the light" in lines[0]
    assert ": noise 0.5 " in lines[1] and "the light is ignored" in lines[1]


def test_communication_averages_the_correlations_size_and_draws_both_measures_against_noise(tmp_path):
    trials = []
    pearson = {"0": [-0.10, 0.12, -0.11], "0.5": [0.20, -0.18, 0.22]}
    success = {"0": [0.80, 0.70, 0.75], "0.5": [0.80, 0.78, 0.79]}
    unheard = {"0": [0.73, 0.64, 0.67], "0.5": [0.81, 0.77, 0.79]}  # lost: 0.07, 0.06, 0.08 and -0.01, 0.01, 0
    for noise, values in pearson.items():
        for seed, r in enumerate(values):
            trials.append({"trial": f"real-junction_lidar_noise={noise}_seed={seed}", "behaviour": "real-junction",
                           "seed": seed, "lidar_noise": noise, "status": "done", "error": "", "report_episodes": 200,
                           "report_first_seed": REPORT.start,
                           "communication.speaker_consistency_bits": 0.1 + seed / 100,
                           "communication.pearson_heading_change_bit": r, "success_rate": success[noise][seed],
                           "messages_unheard.success_rate": unheard[noise][seed]})
    sweep = {"behaviour": "real-junction", "grid": {"lidar_noise": ["0", "0.5"]}, "seeds": 3,
             "fixed": {"communication": "true", "num_cars": "8"}, "timesteps": 5887232, "minutes": None,
             "episodes": 200, "quick": False}
    (tmp_path / "communication.json").write_text(json.dumps({"sweep": sweep, "trials": trials}))
    page = tmp_path / "docs" / "results.md"
    assert main([str(tmp_path / "communication.json"), "--out", str(page)]) == 0
    section = page.read_text().split("## Turn signals (communication)")[1].split("\n## ")[0]
    assert "| \\|Pearson(heading change, bit)\\| |" in section and not ragged_tables(page.read_text())
    assert f"| 0 | 3 | {mean_ci([0.1, 0.11, 0.12]).format()}" in section
    assert f"{mean_ci([0.10, 0.12, 0.11]).format()} (0.100, 0.120, 0.110)" in section  # sizes, not signed values
    assert f"{mean_ci([0.20, 0.18, 0.22]).format()}" in section
    # the same seeds at both levels: paired by seed
    assert "- speaker consistency (bits): noise 0" in section
    assert "no rise detected (paired by seed (3 seeds)" in section
    assert "- |Pearson(heading change, bit)|: noise 0" in section and "rises, paired by seed (3 seeds)" in section
    # the ablation is differenced per trial (the seeds' own success spread cancels), then estimated over seeds
    lost_0, lost_05 = mean_ci([0.07, 0.06, 0.08]), mean_ci([-0.01, 0.01, 0.0])
    assert f"{lost_0.format()} (0.070, 0.060, 0.080) |" in section and f"{lost_05.format()} (-0.010, 0.010, " in section
    # the paper ties reliance to noise, not to one level: the per-level lines claim no agreement
    assert (f"- success lost with messages unheard (lidar_noise=0): {lost_0.format()}: the listeners rely on the "
            "message.\n") in section and "The paper ties the listeners' reliance to noise" in section
    assert "(lidar_noise=0.5): " in section and "straddles zero: neither shown." in section
    assert "- success lost with messages unheard: noise 0" in section and "falls, paired by seed (3 seeds)" in section
    assert (tmp_path / "docs" / "images" / "results" / "communication.png").stat().st_size > 10_000
    assert "## Right of way" in page.read_text()
    assert "Not run yet" in page.read_text().split("## Right of way")[1].split("\n## ")[0]


def test_lanes_and_pedestrian_statements_read_the_intervals():
    from training.results.rule_parts import ONE_SIDED
    from training.results.sections import section, statements

    lanes = [Group({"num_cars": "2"}, [0, 1, 2], {"lanes.majority_share": mean_ci([0.52, 0.60, 0.55]),
                                                  ONE_SIDED: mean_ci([0.02, 0.04, 0.03]),
                                                  "success_rate": mean_ci([0.9] * 3)}),
             Group({"num_cars": "8"}, [0, 1, 2], {"lanes.majority_share": mean_ci([0.97, 1.0, 0.99]),
                                                  ONE_SIDED: mean_ci([0.33, 0.38, 0.32]),
                                                  "success_rate": mean_ci([0.9] * 3)})]
    text = "\n".join(statements(section("lanes"), lanes, {}))
    assert "more one-sided with 8 cars, intervals apart, as in the paper" in text
    assert "- one-sided offset: num_cars=2" in text
    assert "further off the axis on one side with 8 cars, intervals apart" in text
    lanes[1].estimates["lanes.majority_share"] = mean_ci([0.50, 0.70, 0.60])
    assert "no difference detected" in "\n".join(statements(section("lanes"), lanes, {}))

    walk = [Group({}, [0, 1, 2], {"share_more_than_6m": mean_ci([0.99, 0.98, 0.995]),
                                  "success_rate": mean_ci([0.9] * 3)})]
    assert "most samples keep more than 6 m, as in the paper" in "\n".join(statements(section("pedestrians"), walk, {}))
    walk[0].estimates["share_more_than_6m"] = mean_ci([0.2, 0.3, 0.25])
    assert "unlike the paper" in "\n".join(statements(section("pedestrians"), walk, {}))


def test_an_overlap_or_a_straddle_says_how_many_seeds_would_tell():
    from training.results.statements import (
        above_statement,
        apart_statement,
        seeds_needed,
        seeds_needed_apart,
    )

    few = Group({"num_cars": "4"}, [0, 1, 2], {"offset": mean_ci([0.30, 0.35, 0.40])})
    many = Group({"num_cars": "8"}, [0, 1, 2], {"offset": mean_ci([0.20, 0.60, 0.70])})
    line = apart_statement("num_cars", "4", "8", "offset", "one-sided offset", "more with 8")([few, many], {})[0]
    more = seeds_needed_apart([0.30, 0.35, 0.40], [0.20, 0.60, 0.70])
    assert more.startswith("; a planning estimate, taking this difference and spread as true: about ")
    assert line.endswith(f"the intervals overlap: no difference detected{more}.")
    # apart: no seed count
    many.estimates["offset"] = mean_ci([0.60, 0.62, 0.64])
    line = apart_statement("num_cars", "4", "8", "offset", "one-sided offset", "more with 8")([few, many], {})[0]
    assert line.endswith("more with 8, intervals apart, as in the paper.")

    # seeds 0.2 / 0.6 / 0.7 against the level 0.1: distances 0.1 / 0.5 / 0.6 (mean 0.4, sd 0.265); three
    # seeds give 4.303 * 0.265 / sqrt 3 = 0.66 > 0.4, four 3.182 * 0.265 / 2 = 0.42 > 0.4, five
    # 2.776 * 0.265 / sqrt 5 = 0.33 < 0.4: five would tell
    lone = Group({"num_cars": "8"}, [0, 1, 2], {"offset": mean_ci([0.20, 0.60, 0.70])})
    say = above_statement("offset", "one-sided offset", "one side", "on the axis", level=0.1, level_text="0.1")
    planning = "; a planning estimate, taking this mean and spread as true: about 5 seeds would tell"
    assert seeds_needed([0.1, 0.5, 0.6]) == planning
    assert say([lone], {})[0].endswith(f"the interval straddles 0.1: neither shown{planning}.")
    lone.estimates["offset"] = mean_ci([0.5, 0.6, 0.7])
    assert say([lone], {})[0].endswith("one side, as in the paper.")


def test_denser_traffic_is_set_against_the_grids_4_car_row(tmp_path):
    grid = lights_summary(tmp_path / "lights.json", {**VIOLATIONS, ("0.5", "4"): [0.05, 0.07, 0.06]})
    trials = [{"trial": f"lights_seed={s}", "behaviour": "lights", "seed": s, "status": "done", "error": "",
               "report_episodes": 200, "report_first_seed": REPORT.start, "red_light_violation_rate": v,
               "success_rate": 0.9, "collision_rate": 0.1} for s, v in enumerate([0.010, 0.012, 0.011])]
    sweep = {"behaviour": "lights", "grid": {}, "seeds": 3, "timesteps": 991552, "minutes": None, "episodes": 200,
             "quick": False, "fixed": {"num_cars": "8", "lidar_noise": "0.5",
                                       "init_from": "assets/policies/traffic_lights_4cars_noise05"}}
    (tmp_path / "dense.json").write_text(json.dumps({"sweep": sweep, "trials": trials}))
    page = tmp_path / "results.md"
    assert main([str(grid), str(tmp_path / "dense.json"), "--out", str(page)]) == 0
    text = page.read_text()
    dense = text.split("## Denser traffic (8 cars, from the 4-car policy)")[1].split("\n## ")[0]
    assert "- red-light violations: these trials 0.011" in dense
    assert "fewer violations with more cars, intervals apart" in dense
    # the grid keeps its own table
    assert "| 0.5 | 4 | 3 |" in text.split("## Stopping at red lights")[1].split("\n## ")[0]
    assert "0.011" not in text.split("## Stopping at red lights")[1].split("\n## ")[0]


def test_more_violations_with_more_cars_is_not_called_an_overlap():
    from training.results.sections import section, statements

    groups = [Group({"lidar_noise": "0", "num_cars": n}, [0, 1, 2],
                    {"red_light_violation_rate": mean_ci(v), "success_rate": mean_ci([0.9] * 3),
                     "collision_rate": mean_ci([0.1] * 3)})
              for n, v in (("1", [0.10, 0.11, 0.12]), ("4", [0.40, 0.41, 0.42]))]
    text = "\n".join(statements(section("traffic-lights"), groups, {}))
    assert "4 cars" in text and "more violations with more cars, intervals apart, unlike the paper." in text
    assert "overlap" not in text


def test_lights_violations_against_noise_are_read_per_number_of_cars_learnt_points_only():
    from training.results.sections import section, statements

    def point(noise, cars, violations, success=0.9):
        return Group({"lidar_noise": noise, "num_cars": cars}, [0, 1, 2],
                     {"red_light_violation_rate": mean_ci(violations), "success_rate": mean_ci([success] * 3),
                      "collision_rate": mean_ci([0.1] * 3)})

    groups = [point("0", "4", [0.20, 0.21, 0.22]), point("0.5", "4", [0.15, 0.16, 0.17]),
              point("0.75", "4", [0.05, 0.06, 0.07]),
              point("0", "8", [0.10, 0.11, 0.12]), point("0.75", "8", [0.45, 0.46, 0.47], success=0.2)]
    lines = [line for line in statements(section("traffic-lights"), groups, {}) if "against noise" in line
             or line.startswith("- 4 cars") or line.startswith("- 8 cars")]
    # the same seeds at both levels: a paired test (each seed 0.15 lower)
    assert lines == [f"- 4 cars, red-light violations: noise 0 {mean_ci([0.20, 0.21, 0.22]).format()}, noise 0.75 "
                     f"{mean_ci([0.05, 0.06, 0.07]).format()}: falls, paired by seed (3 seeds), high minus low noise "
                     "-0.150 ± 0.000, p < 0.001, as in the paper."]
    groups[2] = point("0.75", "4", [0.30, 0.31, 0.32])
    text = "\n".join(statements(section("traffic-lights"), groups, {}))
    assert "- 4 cars, red-light violations: noise 0" in text and "rises, paired by seed (3 seeds)" in text
    assert "unlike the paper." in text
    groups[2] = point("0.75", "4", [0.10, 0.20, 0.30])
    assert "no fall detected (paired by seed" in "\n".join(statements(section("traffic-lights"), groups, {}))


def test_a_noise_trend_is_paired_by_seed_where_the_seeds_match():
    from training.results.statements import noise_trend, seeds_needed

    def point(noise, violations, seeds=(0, 1, 2)):
        return Group({"lidar_noise": noise}, list(seeds), {"v": mean_ci(violations)})

    # intervals overlap (the seeds differ a lot from each other), but every seed falls by about 0.02
    low, high = point("0.25", [0.10, 0.20, 0.30]), point("1.0", [0.08, 0.18, 0.29])
    diffs = [-0.02, -0.02, -0.01]
    line = noise_trend([low, high], [("v", "violations")], paper=-1)[0]
    d = mean_ci(diffs)
    assert f"falls, paired by seed (3 seeds), high minus low noise {d.mean:+.3f} ± {(d.high - d.low) / 2:.3f}" in line
    assert f"p = {t_test_p(diffs, 0.0):.3f}, as in the paper." in line
    # seeds that do not match (0-2 against 3-5): intervals only
    other = point("1.0", [0.08, 0.18, 0.29], seeds=(3, 4, 5))
    line = noise_trend([low, other], [("v", "violations")], paper=-1)[0]
    # not detected: the largest fall the intervals allow, low's top minus high's bottom
    allow = low.estimates["v"].high - other.estimates["v"].low
    assert f"the intervals overlap: no fall detected; the interval allows a fall of up to {allow:.3f}" in line
    # how many seeds a spread would need: a mean of 0.01 with sd 0.01 needs 7 (t95(6) * 0.01 / sqrt(7) < 0.01)
    assert seeds_needed([0.0, 0.01, 0.02]) == ("; a planning estimate, taking this mean and spread as true: "
                                               "about 7 seeds would tell")
    assert seeds_needed([0.0, 0.0, 0.0]) == ""
    line = noise_trend([low, point("1.0", [0.11, 0.19, 0.30])], [("v", "violations")], paper=-1)[0]
    assert "no fall detected" in line and "unlike the paper" not in line  # not detected is not the opposite
    # paired: the largest fall the interval of the differences allows is minus its lower end
    d = mean_ci([0.01, -0.01, 0.0])
    assert f"; the interval allows a fall of up to {-d.low:.3f}" in line
    # a difference not detected still says how many seeds moved the paper's way (here 1 of 3 fall)
    assert "; 1 of 3 seeds fall; a planning estimate" in line
    # every seed falls, by amounts too spread to show: 3 of 3
    line = noise_trend([low, point("1.0", [0.099, 0.15, 0.25])], [("v", "violations")], paper=-1)[0]
    assert "no fall detected" in line and "; 3 of 3 seeds fall" in line
    # no direction reported by the paper: no count
    assert "seeds fall" not in noise_trend([low, point("1.0", [0.11, 0.19, 0.30])], [("v", "violations")], paper=0)[0]


def test_noise_levels_that_agree_share_one_line_and_unlearnt_rows_one_note():
    from training.results.sections import section, statements

    def point(noise, cars, violations, success=0.9):
        return Group({"lidar_noise": noise, "num_cars": cars}, [0, 1, 2],
                     {"red_light_violation_rate": mean_ci(violations), "success_rate": mean_ci([success] * 3),
                      "collision_rate": mean_ci([0.1] * 3)})

    groups = [point(noise, cars, v, s) for noise in ("0", "0.5") for cars, v, s in
              (("1", [0.40, 0.41, 0.42], 1.0), ("4", [0.05, 0.06, 0.07], 0.9), ("8", [0.45, 0.46, 0.47], 0.2))]
    lines = statements(section("traffic-lights"), groups, {})
    fewer = [line for line in lines if line.startswith("- red-light violations, 1 car against 4 cars")]
    assert len(fewer) == 1 and ", every noise level: noise 0 " in fewer[0] and "; noise 0.5 " in fewer[0]
    assert fewer[0].endswith("fewer violations with more cars, intervals apart, as in the paper.")
    unlearnt = [line for line in lines if "have not learnt" in line]
    assert len(unlearnt) == 1 and unlearnt[0].startswith("- num_cars=8: success noise 0 0.200")
    assert "; noise 0.5 0.200" in unlearnt[0] and "these rows" in unlearnt[0]


def test_every_one_of_a_count_reads_as_english():
    from training.common.markdown import all_of

    assert [all_of(n, "seed", "seeds") for n in (1, 2, 3, 8)] == ["its seed", "both seeds", "all 3 seeds",
                                                                  "all 8 seeds"]
    with pytest.raises(ValueError, match="grid point"):
        all_of(0, "grid point", "grid points")


def test_a_rule_counts_as_learnt_only_beyond_every_scripted_driver():
    from training.results.statements import scripted_baseline_statement

    say = scripted_baseline_statement((("fifo", "FIFO share"),))
    base = {"full-throttle/fifo": (0.71, 200), "random/fifo": (0.80, 200), "random/other": (0.1, 200)}
    learnt = [Group({}, [0, 1, 2], {"fifo": mean_ci([0.90, 0.91, 0.92])})]
    line, = say(learnt, base)
    assert line.startswith("- FIFO share against scripted drivers on the same 200 report episodes "
                           "(the sweep's one setting)")
    assert "full-throttle 0.710, random 0.800" in line and line.endswith("the rule is learnt, as in the paper.")
    inside = [Group({}, [0, 1, 2], {"fifo": mean_ci([0.79, 0.80, 0.81])})]
    assert say(inside, base)[0].endswith("no learnt rule detected (the interval holds random).")
    below = [Group({}, [0, 1, 2], {"fifo": mean_ci([0.60, 0.61, 0.62])})]
    assert say(below, base)[0].endswith("below full-throttle and random: no rule learnt, unlike the paper.")
    # lower is the rule (paper=-1): beyond means below every driver
    lower = scripted_baseline_statement((("fifo", "FIFO share"),), paper=-1)
    assert lower(below, base)[0].endswith("the rule is learnt, as in the paper.")
    assert say(learnt, {}) == []  # no baseline: nothing said


def test_a_reference_driver_is_shown_beside_but_not_in_the_verdict():
    from training.results.data import Size
    from training.results.statements import scripted_baseline_statement

    r = Size("fast_lanes.pearson_r")
    say = scripted_baseline_statement(((r, "|r|"),), references=("oracle",))
    base = {"full-throttle/|fast_lanes.pearson_r|": (0.01, 200), "random/|fast_lanes.pearson_r|": (0.02, 200),
            "axis/|fast_lanes.pearson_r|": (float("nan"), 200),  # nothing varies: no correlation, left out
            "oracle/|fast_lanes.pearson_r|": (0.99, 200)}
    learnt = [Group({}, [0, 1, 2], {r: mean_ci([0.50, 0.52, 0.54])})]
    line, = say(learnt, base)
    assert "full-throttle 0.010, random 0.020 (for comparison, oracle 0.990)" in line and "axis" not in line
    assert line.endswith("beyond every scripted driver: the rule is learnt, as in the paper.")
    without = scripted_baseline_statement(((r, "|r|"),))  # the oracle as a baseline: not beyond it
    assert without(learnt, base)[0].endswith("below oracle: no rule learnt, unlike the paper.")


@pytest.mark.parametrize("space", ["box", "discrete", "multidiscrete"])
def test_random_paths_cover_the_path_space_and_repeat_by_seed(space):
    from gymnasium import spaces

    from training.results.baselines import random_paths

    made = {"box": spaces.Box(-1.0, 1.0, (1,), np.float32), "discrete": spaces.Discrete(5),
            "multidiscrete": spaces.MultiDiscrete([6, 6, 6])}[space]
    obs0 = np.zeros((400, 3))
    a, b = random_paths(made, 7)(obs0), random_paths(made, 7)(obs0)
    assert np.array_equal(a, b) and not np.array_equal(a, random_paths(made, 8)(obs0))
    assert all(made.contains(np.asarray(x).reshape(made.shape)) for x in a)
    assert len(np.unique(a)) > 1  # not one path for all


def test_a_scripted_baseline_scores_every_metric_on_the_trials_episodes():
    from training.results.baselines import scripted_baselines
    from training.results.data import Size

    summary = {"path": "x.json", "trials": [
        {"status": "done", "report_first_seed": 1_500_000_000, "report_episodes": 3, "env_config.num_cars": 10}]}
    r = Size("fast_lanes.pearson_r")
    base = scripted_baselines("highway-spline-v0", (r, "success_rate"),
                              (("blind, random paths", "full-throttle", "random"), ("blind", "full-throttle", "axis")))
    got = base(summary, [])
    assert set(got) == {"blind, random paths/|fast_lanes.pearson_r|", "blind, random paths/success_rate",
                        "blind/|fast_lanes.pearson_r|", "blind/success_rate"}
    assert all(n == 3 for _, n in got.values())
    assert 0.0 <= got["blind, random paths/|fast_lanes.pearson_r|"][0] <= 1.0
    assert np.isnan(got["blind/|fast_lanes.pearson_r|"][0])  # every car on the axis: no correlation
    summary["trials"].append({**summary["trials"][0], "env_config.num_cars": 4})
    two = base(summary, [])  # trials of two car counts: one baseline per count
    assert set(two) == {f"{k}@num_cars={n}" for k in got for n in (4, 10)}
    assert two["blind, random paths/success_rate@num_cars=10"] == got["blind, random paths/success_rate"]


def test_a_baseline_per_car_count_is_set_beside_its_own_rows():
    from training.results.statements import scripted_baseline_statement

    say = scripted_baseline_statement((("share", "majority share"),), claimed=False)
    base = {"random/share@num_cars=4": (0.52, 200), "random/share@num_cars=8": (0.95, 200)}
    groups = [Group({"num_cars": "4"}, [0, 1, 2], {"share": mean_ci([0.80, 0.81, 0.82])}),
              Group({"num_cars": "8"}, [0, 1, 2], {"share": mean_ci([0.80, 0.81, 0.82])})]
    four, eight = say(groups, base)
    assert "(num_cars=4): ours" in four and "random 0.520" in four and four.endswith("learnt.")
    assert "random 0.950" in eight and eight.endswith("below random: not learnt.")
    assert "paper" not in four + eight  # the paper claims no rule at every count: the section's other lines say


def test_an_interval_stays_inside_its_metrics_range():
    from training.results.data import Difference, Size, metric_bounds

    e = mean_ci([0.0, 0.05, 0.3], bounds=(0.0, 1.0))  # the t-interval reaches below 0, not above 1
    raw = mean_ci([0.0, 0.05, 0.3])
    assert raw.low < 0.0 and e.clipped and e.low == 0.0 and e.high == pytest.approx(raw.high)
    assert e.format() == f"{e.mean:.3f} [0.000, {e.high:.3f}]"
    inside = mean_ci([0.4, 0.5, 0.6], bounds=(0.0, 1.0))
    assert not inside.clipped and inside.format() == mean_ci([0.4, 0.5, 0.6]).format()
    assert metric_bounds("success_rate") == (0.0, 1.0) and metric_bounds("mean_time_to_goal") is None
    assert metric_bounds("fast_lanes.pearson_rating_lateral") == (-1.0, 1.0)
    assert metric_bounds(Size("fast_lanes.pearson_rating_lateral")) == (0.0, 1.0)
    assert metric_bounds(Difference("success_rate", "messages_unheard.success_rate")) == (-1.0, 1.0)
    assert metric_bounds("lanes.mean_abs_lane_position") == (0.0, 1.0)


def test_a_lone_car_follows_the_light_only_below_every_rule_free_driver():
    from training.results.statements import lone_car_statement

    drivers = {"full-throttle/red_light_violation_rate": (0.30, 200), "random/red_light_violation_rate": (0.12, 200)}
    follows = Group({}, [0, 1, 2], {"red_light_violation_rate": mean_ci([0.01, 0.02, 0.015])})
    ignores = Group({}, [0, 1, 2], {"red_light_violation_rate": mean_ci([0.10, 0.20, 0.30])})
    line = lone_car_statement([follows], drivers)[0]
    assert line.startswith("- 1 car, red-light violations against rule-free scripted drivers on the same 200 report "
                           "episodes (") and "full-throttle 0.300, random 0.120" in line
    assert line.endswith("below every rule-free driver: the lone car stops for the light, unlike the paper.")
    # an interval that reaches the random driver's rate (0.12) is a light not followed; its reach is said
    line = lone_car_statement([ignores], drivers)[0]
    low = mean_ci([0.10, 0.20, 0.30]).low
    assert line.endswith(f"not below every rule-free driver (our interval reaches down to {max(low, 0.0):.3f}): "
                         "the light is not followed, as in the paper.")
    assert "no width" not in line
    alike = Group({}, [0, 1, 2], {"red_light_violation_rate": mean_ci([0.3, 0.3, 0.3])})  # every seed the same
    line = lone_car_statement([alike], drivers)[0]
    assert "ours 0.300 ± 0.000 (all 3 seeds scored 0.300 on these episodes: the interval over seeds has no " \
           "width" in line
    assert lone_car_statement([ignores], {}) == []  # no baseline measured: nothing said
    one_seed = Group({}, [0], {"red_light_violation_rate": mean_ci([0.2])})
    assert lone_car_statement([one_seed], drivers) == []  # no interval from one seed


def test_a_lone_car_is_set_against_the_4_car_row_with_the_cars_the_right_way_round():
    from training.results.sections import section, statements
    from training.results.statements import reference_statement

    lone = Group({}, [0, 1, 2], {"red_light_violation_rate": mean_ci([0.30, 0.32, 0.31])})
    four = Group({}, [0, 1, 2], {"red_light_violation_rate": mean_ci([0.05, 0.06, 0.07])})
    # the lone car's row has the higher rate: fewer violations with more cars, as the paper says
    line = reference_statement([lone], four, "the 4-car row", more_cars_here=False)[0]
    assert "fewer violations with more cars, intervals apart, as in the paper" in line
    # the same numbers read as if this row had the more cars would say the opposite
    assert "more violations with more cars, intervals apart, unlike the paper" in \
        reference_statement([lone], four, "the 4-car row")[0]
    # the page's lone-car section sets itself against the 4-car preset row that way round
    text = "\n".join(statements(section("traffic-lights-preset-1car"), [lone], {}, four, "the 4-car row"))
    assert "fewer violations with more cars, intervals apart, as in the paper" in text


def test_a_sweep_with_no_trial_finished_yet_is_written_as_planned(tmp_path):
    """A grid just started (its summary holds only stopped and pending trials) has no report
    episodes to score the scripted drivers on: its section says what is planned, no error."""
    names = [f"lights_lidar_noise={n}_num_cars={c}_seed={s}" for (n, c), v in VIOLATIONS.items() for s in range(3)]
    summary = lights_summary(tmp_path / "lights.json", VIOLATIONS,
                             statuses={name: ("stopped" if i < 2 else "pending") for i, name in enumerate(names)})
    page = tmp_path / "results.md"
    assert main([str(summary), "--out", str(page)]) == 0
    part = page.read_text().split("## Stopping at red lights")[1].split("\n## ")[0]
    assert "0 of 12 planned trials done" in part


def test_a_value_that_rounds_to_zero_reads_without_a_minus_sign_and_a_tiny_p_as_a_bound():
    from box2d_driving.metrics.stats import fixed, p_text

    # a least-squares slope over identical values comes out as -1e-17, not 0: the page said "-0.000"
    assert mean_ci([-1e-17, -2e-17, -3e-17]).format() == "0.000 ± 0.000"
    assert fixed(-0.0004) == "0.000" and fixed(-0.0006) == "-0.001" and fixed(-1e-17, 1) == "0.0"
    assert p_text(1e-30) == "p < 0.001" and p_text(0.0004) == "p < 0.001" and p_text(0.0141) == "p = 0.014"
    assert p_text(None).startswith("no p-value")
    assert mean_ci([-0.2, -0.1, -0.3]).format().startswith("-0.200 ± ")
