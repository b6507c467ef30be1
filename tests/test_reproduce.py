"""``box2d-driving reproduce``: the results page from a small hand-built sweep summary."""

from __future__ import annotations

import json
import math
import re
from pathlib import Path

import pytest

from training.results.reproduce import Group, ResultsError, main, trial_budget
from training.common.seeds import REPORT, SELECTION
from training.evaluation.figure_data import LANE_BINS
from training.results.stats import mean_ci, t95, t_test_p


def _ragged_tables(text: str) -> list[str]:
    """Markdown table rows whose number of cells differs from their table's header (an unescaped
    ``|`` inside a cell splits it)."""
    bad, width = [], None
    for line in text.splitlines():
        if not line.startswith("|"):
            width = None
            continue
        cells = len(re.split(r"(?<!\\)\|", line)) - 2
        width = cells if width is None else width
        if cells != width:
            bad.append(line)
    return bad


def _summary(path, violations, first_seed=REPORT.start, statuses=None):
    """A lights sweep over noise {0, 0.5} x cars {1, 4}, 3 seeds, with given violation rates."""
    trials = []
    for (noise, cars), values in violations.items():
        for seed, v in enumerate(values):
            name = f"lights_lidar_noise={noise}_num_cars={cars}_seed={seed}"
            trials.append({"trial": name, "behaviour": "lights", "seed": seed, "lidar_noise": noise,
                           "num_cars": cars, "status": (statuses or {}).get(name, "done"), "error": "",
                           "report_episodes": 200, "report_first_seed": first_seed,
                           "red_light_violation_rate": v, "success_rate": 0.9, "collision_rate": 0.05})
    sweep = {"behaviour": "lights", "grid": {"lidar_noise": ["0", "0.5"], "num_cars": ["1", "4"]},
             "seeds": 3, "fixed": {}, "timesteps": 991552, "minutes": None, "episodes": 200, "quick": False}
    path.write_text(json.dumps({"sweep": sweep, "trials": trials}))
    return path


VIOLATIONS = {("0", "1"): [0.40, 0.47, 0.50], ("0", "4"): [0.10, 0.12, 0.08],
              ("0.5", "1"): [0.30, 0.35, 0.40], ("0.5", "4"): [0.05, 0.07, 0.06]}


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
    assert e.mean == pytest.approx(0.10) and e.high - e.mean == pytest.approx(4.303 * sd / math.sqrt(3))
    assert mean_ci([0.3]).low is None and mean_ci([]).n == 0 and mean_ci([1.0, float("nan")]).n == 1
    assert t95(2) == 4.303 and t95(22) == t95(20) and t95(1000) == 1.96


def test_page_shows_means_intervals_seeds_statements_and_the_figure(tmp_path):
    summary = _summary(tmp_path / "lights.json", VIOLATIONS,
                       statuses={"lights_lidar_noise=0.5_num_cars=4_seed=2": "error"})
    page = tmp_path / "docs" / "results.md"
    assert main([str(summary), "--out", str(page)]) == 0
    text = page.read_text()
    e = mean_ci([0.10, 0.12, 0.08])
    assert f"| 0 | 4 | 3 | {e.format()} (0.100, 0.120, 0.080)" in text
    assert "| 0.5 | 4 | 2 |" in text  # the failed seed is left out and listed
    assert "`lights_lidar_noise=0.5_num_cars=4_seed=2` (error)" in text
    assert "no different: the light is ignored, as in the paper" in text  # 0.457 against the blind 0.415 ± 0.068
    assert "fewer violations with more cars, intervals apart" in text
    assert "11 of 12 planned trials done" in text and "991,552 decisions per trial" in text
    assert "runs them again, from their last checkpoint where their run folder" in text
    assert "have not learnt" not in text  # success 0.9 everywhere
    assert (tmp_path / "docs" / "images" / "results" / "traffic-lights.png").stat().st_size > 10_000
    assert "![Stopping at red lights](images/results/traffic-lights.png)" in text
    for rule in ("## Lanes", "## Right of way", "## Turn signals", "## Fast lanes", "## Slowing down"):
        section = text.split(rule, 1)[1].split("\n## ", 1)[0]
        assert "Not run yet" in section and "box2d-driving sweep" in section
        assert "`box2d-driving reproduce --run --only " in section  # the one command that runs and adds it


def test_a_summary_evaluated_off_report_seeds_is_refused(tmp_path, capsys):
    summary = _summary(tmp_path / "s.json", VIOLATIONS, first_seed=SELECTION.start)
    assert main([str(summary), "--out", str(tmp_path / "r.md")]) == 2
    assert "not on report seeds" in capsys.readouterr().err and not (tmp_path / "r.md").exists()
    (tmp_path / "junk.json").write_text("{}")
    with pytest.raises(ResultsError):
        from training.results.reproduce import load_summary
        load_summary(tmp_path / "junk.json")


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
    # inside the interval: how many seeds this spread would need (differences -0.0145, 0.0055, 0.0105
    # from 0.9845: a mean of 0.0002 against an sd of 0.013, beyond any sweep)
    assert "at this mean and spread more than 200 seeds would be needed" in text


def test_the_t_test_p_value_meets_the_t_table_and_the_obvious_cases():
    from training.results.stats import _T95, incomplete_beta

    for dof, t in _T95.items():  # the tabulated 95 % quantiles give p = 0.05
        assert abs(incomplete_beta(dof / 2, 0.5, dof / (dof + t * t)) - 0.05) < 2e-4
    assert t_test_p([1.0, 2.0, 3.0], 2.0) == pytest.approx(1.0)
    # t = (2 - 0) / (1 / sqrt 3) = 3.464 with 2 dof: p = 0.0742 (tables)
    assert t_test_p([1.0, 2.0, 3.0], 0.0) == pytest.approx(0.0742, abs=5e-4)
    assert t_test_p([0.5], 0.0) is None
    assert t_test_p([0.5, 0.5], 0.0) == 0.0


def test_welch_p_value_and_the_seeds_two_independent_rows_would_need():
    from training.results.stats import welch_p
    from training.results.statements import apart, reference_statement, seeds_needed_apart

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
        "; at this difference and spread about 4 seeds per row would tell"
    assert seeds_needed_apart([0.1, 0.2], [0.1, 0.2]) == ""
    more = Group({}, [0, 1, 2], {"red_light_violation_rate": mean_ci([0.118, 0.134, 0.127])})
    four = Group({}, [0, 1, 2], {"red_light_violation_rate": mean_ci([0.076, 0.077, 0.114])})
    line = reference_statement([more], four, "the 4-car row")[0]
    assert "the intervals overlap: no difference shown, unlike the paper (Welch's t-test p = " in line
    assert f"p = {welch_p([0.118, 0.134, 0.127], [0.076, 0.077, 0.114]):.3f}; at this difference" in line
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
    assert group.figures["lane_position_counts"][len(bins) - 2 - 3] == 20 and group.figures["lane_position_counts"][3] == 0
    assert ran_budget([row, right]) == " (each ran 1,536,000 decisions: whole rollouts)"
    assert ran_budget([row, dict(right, decisions=1_568_000)]) == " (each ran 1,536,000 to 1,568,000 decisions: whole rollouts)"


def test_figure_data_counts_in_fixed_bins():
    import numpy as np

    from training.evaluation import figure_data as fd

    table = {"in_junction": np.array([True, True, True, False]), "lane_offset": np.array([0.5, 0.55, -0.9, 0.5])}
    counts = fd.figure_data("intersection-spline-v0", table, None)["lane_position_counts"]
    assert sum(counts) == 3 and len(counts) == len(fd.LANE_BINS) - 1
    assert counts[int(np.searchsorted(fd.LANE_BINS, 0.5, side="right")) - 1] == 2
    assert fd.figure_data("intersection-v0", table, None) == {}


def test_lanes_page_draws_the_lane_position_histograms_summed_over_seeds(tmp_path):
    from training.evaluation import figure_data as fd

    n = len(fd.LANE_BINS) - 1
    right = [0] * n
    right[-3] = 10
    spread = [1] * n
    trials = [{"trial": f"lanes_num_cars={c}_seed={s}", "behaviour": "lanes", "seed": s, "num_cars": c,
               "status": "done", "report_episodes": 200, "report_first_seed": REPORT.start,
               "lanes.majority_share": 1.0 if c == "8" else 0.5, "lanes.time_share_majority": 0.9,
               "success_rate": 0.9, "figures": {"lane_position_counts": right if c == "8" else spread}}
              for c in ("2", "8") for s in range(2)]
    sweep = {"behaviour": "lanes", "grid": {"num_cars": ["2", "8"]}, "seeds": 2, "fixed": {},
             "timesteps": None, "minutes": None, "episodes": 200, "quick": False}
    path = tmp_path / "lanes.json"
    path.write_text(json.dumps({"sweep": sweep, "trials": trials}))
    from training.results.reproduce import groups_of, load_summary

    groups = groups_of(load_summary(path), ["lanes.majority_share"])
    assert groups[1].figures["lane_position_counts"][-3] == 20  # two seeds summed
    assert main([str(path), "--out", str(tmp_path / "results.md")]) == 0
    text = (tmp_path / "results.md").read_text()
    assert "![Lanes](images/results/lanes.png)" in text
    assert (tmp_path / "images" / "results" / "lanes.png").stat().st_size > 5_000


def test_summary_rows_keep_figures_in_the_json_only(tmp_path):
    import csv as csv_module

    from training.sweeps.spec import SweepSpec
    from training.sweeps.summary import summary_row, write_summary

    trial = {"name": "t", "behaviour": "lanes", "seed": 0, "point": {}}
    row = summary_row(trial, "done", {"report/success_rate": 0.5, "figures/lane_position_counts": [1, 2]})
    assert row["figures"] == {"lane_position_counts": [1, 2]}
    write_summary(tmp_path, SweepSpec("lanes"), [row])
    assert json.loads((tmp_path / "summary.json").read_text())["trials"][0]["figures"]["lane_position_counts"] == [1, 2]
    header = next(csv_module.reader((tmp_path / "summary.csv").open()))
    assert "figures" not in header and "success_rate" in header


def test_gifs_animate_the_shipped_policy_and_the_page_links_them(tmp_path):
    import dataclasses

    from training.results import reproduce

    section = next(s for s in reproduce.SECTIONS if s.key == "traffic-lights")
    small = dataclasses.replace(section, gif_size=(96, 96))
    gif = reproduce.write_gif(small, tmp_path / "images" / "traffic-lights.gif")
    import imageio.v2 as imageio

    frames = imageio.mimread(gif)
    assert len(frames) > 5 and frames[0].shape[:2] == (96, 96)
    text = reproduce.write_page([], tmp_path / "results.md", tmp_path / "images")
    assert "![Stopping at red lights: the shipped policy](images/traffic-lights.gif)" in text


def test_seeds_a_command_asks_beyond_its_summary_count_as_planned(tmp_path, monkeypatch):
    """A section whose command now asks a fourth seed: the page plans it before any run adds it."""
    import dataclasses

    from training.results import reproduce

    summary = _summary(tmp_path / "lights.json", VIOLATIONS)
    section = next(s for s in reproduce.SECTIONS if s.summary_name == "lights")
    assert section.seeds == 3
    more = dataclasses.replace(section, command=section.command.replace("--seeds 3", "--seeds 4"))
    monkeypatch.setattr(reproduce, "SECTIONS", tuple(more if s is section else s for s in reproduce.SECTIONS))
    page = tmp_path / "results.md"
    assert main([str(summary), "--out", str(page)]) == 0
    assert "12 of 16 planned trials done" in page.read_text()


def test_every_rules_rerun_command_is_a_valid_sweep():
    import shlex

    from training.results.reproduce import SECTIONS
    from training.sweeps.spec import check_spec

    for section in SECTIONS:
        argv = shlex.split(section.command)
        assert argv[:2] == ["box2d-driving", "sweep"], section.key
        spec, _ = section.spec()  # the reading `reproduce --run` hands to Ray Tune
        assert spec.behaviour == section.behaviour
        assert (section.out, section.seeds) == (Path(argv[argv.index("--out") + 1]), spec.seeds), section.key
        check_spec(spec)  # every trial's options parse and make a valid config


def _tiny_section(setting="A tiny grid."):
    """A rule whose sweep is two tiny trials (1 and 2 cars, one seed) from a shipped policy."""
    from pathlib import Path

    from training.results.sections import Section

    shipped = Path(__file__).resolve().parent.parent / "assets" / "policies" / "traffic_lights_4cars"
    return Section("traffic-lights", "Stopping at red lights", "lights", (),
                   (("red_light_violation_rate", "red-light violations"), ("success_rate", "success")),
                   "The paper's claim.",
                   "box2d-driving sweep lights --grid num_cars=1,2 --seeds 1 --timesteps 160 --episodes 2 "
                   f"--set n_envs=2 batch_decisions=80 epochs=1 init_from={shipped} --out runs/sweep-tiny",
                   setting=setting)


def test_run_sweeps_every_rule_keeps_its_summary_and_a_fresh_machine_continues_from_it(tmp_path, monkeypatch):
    import shutil

    import ray

    from training.results import reproduce

    from training.sweeps import curves

    monkeypatch.setattr(reproduce, "SECTIONS", (_tiny_section(),))
    monkeypatch.setattr(curves, "SWEEP_CURVE_EPISODES", 2)
    folder, runs, page = tmp_path / "sweeps", tmp_path / "runs", tmp_path / "results.md"
    argv = ["--run", "--summaries", str(folder), "--runs", str(runs), "--out", str(page), "--max-concurrent", "1"]
    try:
        assert reproduce.main(argv) == 0
        first = json.loads((folder / "tiny.json").read_text())["trials"]
        assert sorted(r["status"] for r in first) == ["done", "done"]
        assert all(r["report_first_seed"] in REPORT and r["report_episodes"] == 2 for r in first)
        assert (folder / "tiny.csv").exists() and (runs / "sweep-tiny" / "summary.json").exists()
        text = page.read_text()
        assert "2 of 2 planned trials done" in text and "A tiny grid." in text and "summary `" in text
        # the learning curves on selection seeds, beside the summary, and on the page
        curves = (folder / "curves" / "tiny.csv").read_text()
        assert {r["trial"] for r in first} == {line.split(",")[0] for line in curves.splitlines()[1:]}
        assert "**Learning curves**" in text

        # another machine: no sweep folder, only the kept summary -> nothing is trained again
        shutil.rmtree(runs)
        assert reproduce.main(argv) == 0
        assert not list((runs / "sweep-tiny" / "tune").glob("*/checkpoint_*"))
        again = json.loads((folder / "tiny.json").read_text())["trials"]
        key = lambda rows: {r["trial"]: (r["success_rate"], r["red_light_violation_rate"], r["run"]) for r in rows}  # noqa: E731
        assert key(again) == key(first)
        assert (folder / "curves" / "tiny.csv").read_text() == curves  # kept: no run folder here to redraw them
    finally:
        ray.shutdown()


def test_run_refuses_a_kept_summary_of_another_sweep_before_training(tmp_path, monkeypatch, capsys):
    from training.results import reproduce
    from training.sweeps.spec import SweepSpec
    from training.sweeps.summary import write_summary

    monkeypatch.setattr(reproduce, "SECTIONS", (_tiny_section(),))
    folder = tmp_path / "sweeps"
    write_summary(tmp_path, SweepSpec("lights", grid={"num_cars": ["4"]}), [])
    folder.mkdir()
    (tmp_path / "summary.json").rename(folder / "tiny.json")
    code = reproduce.main(["--run", "--summaries", str(folder), "--runs", str(tmp_path / "runs"),
                           "--out", str(tmp_path / "results.md")])
    err = capsys.readouterr().err
    assert code == 2 and "traffic-lights" in err and "another sweep" in err, err
    assert not (tmp_path / "runs").exists() and not (tmp_path / "results.md").exists()
    # a README without the result markers: refused before training too
    (tmp_path / "README.md").write_text("# no markers\n")
    (folder / "tiny.json").unlink()
    code = reproduce.main(["--run", "--summaries", str(folder), "--runs", str(tmp_path / "runs"),
                           "--out", str(tmp_path / "results.md"), "--readme", str(tmp_path / "README.md")])
    assert code == 2 and "--readme" in capsys.readouterr().err and not (tmp_path / "runs").exists()
    with pytest.raises(SystemExit) as exit_:
        reproduce.main(["--only", "traffic-lights"])  # without --run
    assert exit_.value.code == 2 and "--only goes with --run" in capsys.readouterr().err


def test_readme_table_shows_each_rules_headline_over_seeds_and_links_its_section(tmp_path, capsys):
    from training.results.reproduce import README_END, README_START

    summary = _summary(tmp_path / "lights.json", {**VIOLATIONS, ("0.5", "4"): [0.05, 0.07]})
    readme = tmp_path / "README.md"
    readme.write_text(f"# Title\n\nbefore\n{README_START}\nold table\n{README_END}\nafter\n")
    page = tmp_path / "docs" / "results.md"
    assert main([str(summary), "--out", str(page), "--readme", str(readme)]) == 0
    text = readme.read_text()
    assert text.startswith("# Title\n\nbefore\n") and text.endswith(f"{README_END}\nafter\n") and "old table" not in text
    row = next(line for line in text.splitlines() if line.startswith("| stop at red lights |"))
    assert f"red-light violations {mean_ci([0.05, 0.07]).format()}" in row and "| 2 |" in row
    assert "(docs/results.md#stopping-at-red-lights)" in row
    lone = next(line for line in text.splitlines() if line.startswith("| lone car ignores"))
    assert f"red-light violations {mean_ci([0.30, 0.35, 0.40]).format()}" in lone and "| 3 |" in lone
    assert "| lanes emerge |" in text and "not run yet | 0 | [Lanes](docs/results.md#lanes)" in text

    # a README without the markers: one clear error, nothing written
    readme.write_text("# no markers\n")
    page.unlink()
    assert main([str(summary), "--out", str(page), "--readme", str(readme)]) == 2
    assert "--readme" in capsys.readouterr().err and not page.exists() and readme.read_text() == "# no markers\n"


def test_the_committed_page_and_readme_table_match_the_committed_summaries(tmp_path, monkeypatch):
    """docs/results.md and the README's table are what `box2d-driving reproduce --readme README.md`
    writes from assets/sweeps: nobody edited a number by hand, no summary was left out."""
    import shutil
    from pathlib import Path

    from training.results.reproduce import README_END, README_START, default_summaries, load_summary, readme_table, write_page

    root = Path(__file__).resolve().parent.parent
    monkeypatch.chdir(root)
    summaries = [load_summary(p) for p in default_summaries(Path("assets/sweeps"))]
    readme = (root / "README.md").read_text()
    assert readme.split(README_START + "\n")[1].split("\n" + README_END)[0] == readme_table(summaries)
    assert not _ragged_tables(readme) and not _ragged_tables((root / "docs" / "results.md").read_text())
    page, figures = tmp_path / "docs" / "results.md", tmp_path / "docs" / "images" / "results"
    shutil.copytree(root / "docs" / "images" / "results", figures)  # the animations are linked, not drawn
    assert write_page(summaries, page, figures) == (root / "docs" / "results.md").read_text()


def test_a_grid_point_whose_cars_do_not_arrive_is_called_unlearnt(tmp_path):
    summary = json.loads(_summary(tmp_path / "s.json", VIOLATIONS).read_text())
    for row in summary["trials"]:
        if row["num_cars"] == "4" and row["lidar_noise"] == "0":
            row["success_rate"] = 0.3
    (tmp_path / "s.json").write_text(json.dumps(summary))
    page = tmp_path / "results.md"
    assert main([str(tmp_path / "s.json"), "--out", str(page)]) == 0
    notes = [line for line in page.read_text().splitlines() if "have not learnt" in line]
    assert len(notes) == 1 and notes[0].startswith("- lidar_noise=0, num_cars=4: success 0.300")


def test_a_lone_car_that_stops_on_red_is_told_apart_from_a_light_blind_driver(tmp_path):
    from training.results.data import light_blind_violation_rate

    blind = light_blind_violation_rate(1, 0.0, REPORT.start, 200)
    assert 0.3 < blind < 0.6  # full throttle enters on red about as often as on green
    summary = _summary(tmp_path / "s.json", {**VIOLATIONS, ("0", "1"): [0.05, 0.06, 0.04]})
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
                           "report_first_seed": REPORT.start, "communication.speaker_consistency_bits": 0.1 + seed / 100,
                           "communication.pearson_heading_change_bit": r, "success_rate": success[noise][seed],
                           "messages_unheard.success_rate": unheard[noise][seed]})
    sweep = {"behaviour": "real-junction", "grid": {"lidar_noise": ["0", "0.5"]}, "seeds": 3,
             "fixed": {"communication": "true", "num_cars": "8"}, "timesteps": 5887232, "minutes": None,
             "episodes": 200, "quick": False}
    (tmp_path / "communication.json").write_text(json.dumps({"sweep": sweep, "trials": trials}))
    page = tmp_path / "docs" / "results.md"
    assert main([str(tmp_path / "communication.json"), "--out", str(page)]) == 0
    section = page.read_text().split("## Turn signals (communication)")[1].split("\n## ")[0]
    assert "| \\|Pearson(heading change, bit)\\| |" in section and not _ragged_tables(page.read_text())
    assert f"| 0 | 3 | {mean_ci([0.1, 0.11, 0.12]).format()}" in section
    assert f"{mean_ci([0.10, 0.12, 0.11]).format()} (0.100, 0.120, 0.110)" in section  # sizes, not signed values
    assert f"{mean_ci([0.20, 0.18, 0.22]).format()}" in section
    # the same seeds at both levels: paired by seed
    assert "- speaker consistency (bits): noise 0" in section and "no rise shown (paired by seed (3 seeds)" in section
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
    assert "## Right of way" in page.read_text() and "Not run yet" in page.read_text().split("## Right of way")[1].split("\n## ")[0]


def test_lanes_and_pedestrian_statements_read_the_intervals():
    from training.results.sections import section, statements

    from training.results.rule_parts import ONE_SIDED

    lanes = [Group({"num_cars": "2"}, [0, 1, 2], {"lanes.majority_share": mean_ci([0.52, 0.60, 0.55]),
                                                  ONE_SIDED: mean_ci([0.02, 0.04, 0.03]),
                                                  "success_rate": mean_ci([0.9] * 3)}),
             Group({"num_cars": "8"}, [0, 1, 2], {"lanes.majority_share": mean_ci([0.97, 1.0, 0.99]),
                                                  ONE_SIDED: mean_ci([0.33, 0.38, 0.32]),
                                                  "success_rate": mean_ci([0.9] * 3)})]
    text = "\n".join(statements(section("lanes"), lanes, {}))
    assert "more one-sided with 8 cars, intervals apart, as in the paper" in text
    assert "- one-sided offset: num_cars=2" in text and "further off the axis on one side with 8 cars, intervals apart" in text
    lanes[1].estimates["lanes.majority_share"] = mean_ci([0.50, 0.70, 0.60])
    assert "no difference shown, unlike the paper" in "\n".join(statements(section("lanes"), lanes, {}))

    walk = [Group({}, [0, 1, 2], {"share_more_than_6m": mean_ci([0.99, 0.98, 0.995]), "success_rate": mean_ci([0.9] * 3)})]
    assert "most samples keep more than 6 m, as in the paper" in "\n".join(statements(section("pedestrians"), walk, {}))
    walk[0].estimates["share_more_than_6m"] = mean_ci([0.2, 0.3, 0.25])
    assert "unlike the paper" in "\n".join(statements(section("pedestrians"), walk, {}))


def test_an_overlap_or_a_straddle_says_how_many_seeds_would_tell():
    from training.results.statements import above_statement, apart_statement, seeds_needed, seeds_needed_apart

    few = Group({"num_cars": "4"}, [0, 1, 2], {"offset": mean_ci([0.30, 0.35, 0.40])})
    many = Group({"num_cars": "8"}, [0, 1, 2], {"offset": mean_ci([0.20, 0.60, 0.70])})
    line = apart_statement("num_cars", "4", "8", "offset", "one-sided offset", "more with 8")([few, many], {})[0]
    more = seeds_needed_apart([0.30, 0.35, 0.40], [0.20, 0.60, 0.70])
    assert more.startswith("; at this difference and spread about ")
    assert line.endswith(f"the intervals overlap: no difference shown, unlike the paper{more}.")
    # apart: no seed count
    many.estimates["offset"] = mean_ci([0.60, 0.62, 0.64])
    line = apart_statement("num_cars", "4", "8", "offset", "one-sided offset", "more with 8")([few, many], {})[0]
    assert line.endswith("more with 8, intervals apart, as in the paper.")

    # seeds 0.2 / 0.6 / 0.7 against the level 0.1: distances 0.1 / 0.5 / 0.6 (mean 0.4, sd 0.265); three
    # seeds give 4.303 * 0.265 / sqrt 3 = 0.66 > 0.4, four 3.182 * 0.265 / 2 = 0.42 > 0.4, five
    # 2.776 * 0.265 / sqrt 5 = 0.33 < 0.4: five would tell
    lone = Group({"num_cars": "8"}, [0, 1, 2], {"offset": mean_ci([0.20, 0.60, 0.70])})
    say = above_statement("offset", "one-sided offset", "one side", "on the axis", level=0.1, level_text="0.1")
    assert seeds_needed([0.1, 0.5, 0.6]) == "; at this mean and spread about 5 seeds would tell"
    assert say([lone], {})[0].endswith(
        "the interval straddles 0.1: neither shown; at this mean and spread about 5 seeds would tell.")
    lone.estimates["offset"] = mean_ci([0.5, 0.6, 0.7])
    assert say([lone], {})[0].endswith("one side, as in the paper.")


def test_denser_traffic_is_set_against_the_grids_4_car_row(tmp_path):
    grid = _summary(tmp_path / "lights.json", {**VIOLATIONS, ("0.5", "4"): [0.05, 0.07, 0.06]})
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
    dense = text.split("## Denser traffic")[1].split("\n## ")[0]
    assert "- red-light violations: these trials 0.011" in dense and "fewer violations with more cars, intervals apart" in dense
    assert "| 0.5 | 4 | 3 |" in text.split("## Stopping at red lights")[1].split("\n## ")[0]  # the grid keeps its own table
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
                     "-0.150 ± 0.000, p = 0.000, as in the paper."]
    groups[2] = point("0.75", "4", [0.30, 0.31, 0.32])
    text = "\n".join(statements(section("traffic-lights"), groups, {}))
    assert "- 4 cars, red-light violations: noise 0" in text and "rises, paired by seed (3 seeds)" in text
    assert "unlike the paper." in text
    groups[2] = point("0.75", "4", [0.10, 0.20, 0.30])
    assert "no fall shown (paired by seed" in "\n".join(statements(section("traffic-lights"), groups, {}))


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
    assert "the intervals overlap: no fall shown" in noise_trend([low, other], [("v", "violations")], paper=-1)[0]
    # how many seeds a spread would need: a mean of 0.01 with sd 0.01 needs 7 (t95(6) * 0.01 / sqrt(7) < 0.01)
    assert seeds_needed([0.0, 0.01, 0.02]) == "; at this mean and spread about 7 seeds would tell"
    assert seeds_needed([0.0, 0.0, 0.0]) == ""
    assert "no fall shown" in noise_trend([low, point("1.0", [0.11, 0.19, 0.30])], [("v", "violations")], paper=-1)[0]
    # a difference not shown still says how many seeds moved the paper's way (here 1 of 3 fall)
    assert ", unlike the paper; 1 of 3 seeds fall; at this mean" in noise_trend(
        [low, point("1.0", [0.11, 0.19, 0.30])], [("v", "violations")], paper=-1)[0]
    # every seed falls, by amounts too spread to show: 3 of 3
    line = noise_trend([low, point("1.0", [0.099, 0.15, 0.25])], [("v", "violations")], paper=-1)[0]
    assert "no fall shown" in line and "; 3 of 3 seeds fall" in line
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


def test_a_trials_budget_is_said_in_its_own_unit():
    base = {"fixed": {}, "timesteps": None, "minutes": None}
    assert trial_budget({**base, "timesteps": 991552}) == "991,552 decisions"
    assert trial_budget({**base, "fixed": {"rounds": "48"}}) == "48 bilevel rounds"  # lanes, fast lanes
    assert trial_budget({**base, "fixed": {"rounds": "48"}, "minutes": 30.0}) == "48 bilevel rounds (at most 30 min)"
    assert trial_budget(base) == "the behaviour's default budget"
    over_rounds = {**base, "grid": {"rounds": ["24", "48"]}}  # a sweep over budgets: each row says its own
    assert trial_budget(over_rounds) == "the bilevel rounds in the table's `rounds` column"


def test_every_section_states_the_papers_budget_beside_ours_and_the_plateau_question():
    from training.results.reproduce import budget_note
    from training.results.sections import section

    assert "The paper's runs: 8 cars, all junctions, 1,000 epochs (32 M decisions)." in budget_note(section("right-of-way"))
    assert "not known to us" in budget_note(section("fast-lanes"))
    from training.results.sections import SECTIONS

    assert all("stopped moving" in budget_note(s) for s in SECTIONS)


def _paper_lights(folder, violations):
    """The paper-settings lights sweep: 4 cars fixed, noise in the grid, 3 seeds."""
    trials = [{"trial": f"lights_lidar_noise={noise}_seed={seed}", "behaviour": "lights", "seed": seed,
               "lidar_noise": noise, "status": "done", "error": "", "report_episodes": 200,
               "report_first_seed": REPORT.start, "red_light_violation_rate": v, "success_rate": 0.95,
               "collision_rate": 0.05, "decisions": 2400000}
              for noise, values in violations.items() for seed, v in enumerate(values)]
    sweep = {"behaviour": "lights", "grid": {"lidar_noise": list(violations)}, "seeds": 3,
             "fixed": {"num_cars": "4"}, "timesteps": 2400000, "minutes": None, "episodes": 200, "quick": False}
    path = folder / "lights-paper.json"
    path.write_text(json.dumps({"sweep": sweep, "trials": trials}))
    return path


def test_the_paper_settings_sweep_has_its_own_section_and_its_learning_curves(tmp_path):
    import csv

    grid = _summary(tmp_path / "lights.json", VIOLATIONS)
    paper = _paper_lights(tmp_path, {"0.25": [0.111, 0.112, 0.113], "1.0": [0.061, 0.062, 0.063]})
    page = tmp_path / "docs" / "results.md"
    assert main([str(grid), str(paper), "--out", str(page)]) == 0
    text = page.read_text()
    mine = text.split("## Stopping at red lights, at the paper's settings")[1].split("\n## ")[0]
    grid_part = text.split("## Stopping at red lights\n")[1].split("\n## ")[0]
    assert "| 1.0 | 3 | 0.062" in mine and "0.062" not in grid_part  # the more specific section only
    assert "falls, paired by seed (3 seeds)" in mine
    assert "is not measured (the sweep's checkpoints were not kept" in mine and "Learning curves" not in mine

    # curves committed beside the summary: noise 0.25 flat, noise 1.0 still falling
    (tmp_path / "curves").mkdir()
    with open(tmp_path / "curves" / "lights-paper.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=["trial", "seed", "lidar_noise", "decisions", "agent_steps", "episodes",
                                          "first_seed", "success_rate", "collision_rate", "red_light_violation_rate"])
        w.writeheader()
        for noise in ("0.25", "1.0"):
            for seed in range(3):
                for k in range(1, 9):
                    d = 320_000 * k
                    v = 0.11 if noise == "0.25" else 0.3 - (0.02 + 0.001 * seed) * k
                    w.writerow({"trial": f"lights_lidar_noise={noise}_seed={seed}", "seed": seed, "lidar_noise": noise, "decisions": d,
                                "agent_steps": d * 0.7, "episodes": 100, "first_seed": SELECTION.start,
                                "success_rate": 0.9, "collision_rate": 0.1, "red_light_violation_rate": v})
    assert main([str(grid), str(paper), "--out", str(page)]) == 0
    mine = page.read_text().split("## Stopping at red lights, at the paper's settings")[1].split("\n## ")[0]
    assert "the learning curves below" in mine and f"selection seeds from {SELECTION.start:,}" in mine
    line = next(x for x in mine.splitlines() if x.startswith("- red-light violations, change over the last 50 %"))
    assert "the last 1.28 M decisions" in line
    assert "lidar_noise 0.25 0.000 ± 0.000 (stopped moving)" in line
    # noise 1.0 falls 0.020-0.022 per 320,000 decisions: over the last 1.28 M, 4 of those steps
    falls = mean_ci([-(0.02 + 0.001 * s) * 4 for s in range(3)])
    assert f"lidar_noise 1.0 {falls.format()} (still falling)" in line
    assert (tmp_path / "docs" / "images" / "results" / "traffic-lights-paper_curves.png").stat().st_size > 10_000
    assert "of the 6 finished trials" not in mine  # the curves cover every finished trial
    # curves of only some trials (the others finished on a machine that kept no checkpoints) say which
    path = tmp_path / "curves" / "lights-paper.csv"
    lines = path.read_text().splitlines()
    path.write_text("\n".join(x for x in lines if "noise=1.0_seed=2," not in x) + "\n")
    assert main([str(grid), str(paper), "--out", str(page)]) == 0
    mine = page.read_text().split("## Stopping at red lights, at the paper's settings")[1].split("\n## ")[0]
    assert ("; 5 of the 6 finished trials (lights_lidar_noise=0.25_seed=0, lights_lidar_noise=0.25_seed=1, "
            "lights_lidar_noise=0.25_seed=2, lights_lidar_noise=1.0_seed=0, lights_lidar_noise=1.0_seed=1): the "
            "others ran where their checkpoints were not kept):") in mine
    # a file that is not a sweep's curves is refused with the page's own error
    (tmp_path / "curves" / "lights-paper.csv").write_text("a,b\n1,2\n")
    assert main([str(grid), str(paper), "--out", str(page)]) == 2


def test_the_same_fine_tune_at_a_larger_budget_has_its_own_section(tmp_path):
    fixed = {"num_cars": "8", "lidar_noise": "0.5", "init_from": "assets/policies/traffic_lights_4cars_noise05"}
    paths = []
    for name, budget, values in (("short", 991552, [0.010, 0.012, 0.011]), ("long", 2400000, [0.031, 0.032, 0.033])):
        trials = [{"trial": f"lights_seed={s}", "behaviour": "lights", "seed": s, "status": "done", "error": "",
                   "report_episodes": 200, "report_first_seed": REPORT.start, "red_light_violation_rate": v,
                   "success_rate": 0.9, "collision_rate": 0.1} for s, v in enumerate(values)]
        sweep = {"behaviour": "lights", "grid": {}, "seeds": 3, "timesteps": budget, "minutes": None,
                 "episodes": 200, "quick": False, "fixed": fixed}
        paths.append(tmp_path / f"{name}.json")
        paths[-1].write_text(json.dumps({"sweep": sweep, "trials": trials}))
    page = tmp_path / "results.md"
    assert main([str(p) for p in paths] + ["--out", str(page)]) == 0
    text = page.read_text()
    short = text.split("## Denser traffic (8 cars")[1].split("\n## ")[0]
    long = text.split("## Denser traffic, trained longer")[1].split("\n## ")[0]
    assert "0.011" in short and "0.032" not in short
    assert "0.032" in long and "0.011" not in long


def _lanes(path, rounds, cars, shares):
    """A lanes sweep summary at ``rounds`` bilevel rounds: ``shares`` per car count, 3 seeds."""
    n_bins = len(LANE_BINS) - 1
    trials = []
    for n, values in zip(cars, shares):
        for seed, v in enumerate(values):
            counts = [0] * n_bins
            counts[n_bins // 2 + 3] = 100  # one-sided: every sample off the axis on the + side
            trials.append({"trial": f"lanes_num_cars={n}_seed={seed}", "behaviour": "lanes", "seed": seed,
                           "num_cars": str(n), "status": "done", "error": "", "report_episodes": 200,
                           "report_first_seed": REPORT.start, "decisions": rounds * 32000,
                           "lanes.majority_share": v, "lanes.time_share_majority": v,
                           "lanes.mean_abs_lane_position": 0.3, "success_rate": 0.9,
                           "figures": {"lane_position_counts": counts}})
    sweep = {"behaviour": "lanes", "grid": {"num_cars": [str(n) for n in cars]}, "seeds": 3,
             "fixed": {"lidar_noise": "0.5", "rounds": str(rounds)}, "timesteps": None, "minutes": None,
             "episodes": 200, "quick": False}
    path.write_text(json.dumps({"sweep": sweep, "trials": trials}))
    return path


def test_lanes_at_the_papers_budget_have_their_own_section(tmp_path):
    short = _lanes(tmp_path / "lanes.json", 48, (2, 8), ([0.51, 0.52, 0.53], [0.97, 0.98, 0.99]))
    paper = _lanes(tmp_path / "lanes-paper.json", 150, (8, 4), ([0.991, 0.992, 0.993], [0.61, 0.62, 0.63]))
    page = tmp_path / "docs" / "results.md"
    assert main([str(short), str(paper), "--out", str(page)]) == 0
    text = page.read_text()
    mine = text.split("## Lanes, at the paper's smallest budget")[1].split("\n## ")[0]
    grid = text.split("## Lanes\n")[1].split("\n## ")[0]
    assert "| 4 | 3 | 0.620" in mine and "0.620" not in grid and "| 2 | 3 | 0.520" in grid
    assert "0.992" in mine and "0.992" not in grid  # the 150-round 8-car trials: the more specific section only
    assert "crossings on the majority side: num_cars=4 0.620" in mine and "intervals apart" in mine
    # the paper's 4 cars form no lanes: whether each car count keeps to one side is said, and the
    # offsets' difference alone names no agreement with the paper
    assert "- one-sided offset (num_cars=4): " in mine and ": the cars keep to one side." in mine
    assert "The paper: lanes with 8 cars, none with 4." in mine
    offset_line = next(x for x in mine.splitlines() if x.startswith("- one-sided offset: num_cars=4"))
    assert "paper" not in offset_line
    # curves beside the summary: the one-sided offset is judged from the curve's own column
    import csv

    (tmp_path / "curves").mkdir()
    cols = ["trial", "seed", "num_cars", "decisions", "agent_steps", "episodes", "first_seed", "success_rate",
            "collision_rate", "red_light_violation_rate", "lanes.majority_share", "lanes.time_share_majority",
            "lanes.mean_abs_lane_position", "lanes.one_sided_offset"]
    with open(tmp_path / "curves" / "lanes-paper.csv", "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=cols)
        w.writeheader()
        for n in (8, 4):
            for seed in range(3):
                for k in range(1, 16):
                    d = 320_000 * k
                    w.writerow({"trial": f"t{n}{seed}", "seed": seed, "num_cars": n, "decisions": d,
                                "agent_steps": d // 2, "episodes": 100, "first_seed": SELECTION.start,
                                "success_rate": 0.9, "collision_rate": 0.1, "red_light_violation_rate": 0.1,
                                "lanes.majority_share": 1.0, "lanes.time_share_majority": 1.0,
                                "lanes.mean_abs_lane_position": 0.3,
                                "lanes.one_sided_offset": 0.3 if n == 8 else 0.1 + 0.01 * k})
    assert main([str(short), str(paper), "--out", str(page)]) == 0
    mine = page.read_text().split("## Lanes, at the paper's smallest budget")[1].split("\n## ")[0]
    line = next(x for x in mine.splitlines() if x.startswith("- one-sided offset, change over the last 50 %"))
    assert "num_cars 8 0.000 ± 0.000 (stopped moving)" in line and "num_cars 4 0.0" in line and "(still rising)" in line


def test_lanes_with_the_papers_joint_path_choice_have_their_own_section(tmp_path):
    paper = _lanes(tmp_path / "lanes-paper.json", 150, (8, 4), ([0.991, 0.992, 0.993], [0.97, 0.98, 0.99]))
    joint = _lanes(tmp_path / "lanes-joint.json", 150, (8, 4), ([0.81, 0.82, 0.83], [0.51, 0.52, 0.53]))
    data = json.loads(joint.read_text())
    data["sweep"]["fixed"]["spline_action"] = "joint"
    joint.write_text(json.dumps(data))
    page = tmp_path / "docs" / "results.md"
    assert main([str(paper), str(joint), "--out", str(page)]) == 0
    text = page.read_text()
    mine = text.split("## Lanes with the paper's single 216-way path choice")[1].split("\n## ")[0]
    theirs = text.split("## Lanes, at the paper's smallest budget")[1].split("\n## ")[0]
    assert "| 4 | 3 | 0.520" in mine and "0.520" not in theirs  # each sweep in its own section only
    assert "| 4 | 3 | 0.980" in theirs and "0.980" not in mine
    assert "crossings on the majority side: num_cars=4 0.520" in mine and "The paper: lanes with 8 cars" in mine


def _lanes_noise(path, offsets, fixed=None):
    """A 150-round lanes sweep over cars {8, 4} x LiDAR noise {0, 1.0}: ``offsets`` (signed one-sided
    offsets of seeds 0-2) per (cars, noise); ``fixed``: its fixed options (default: those of
    :func:`_lanes` less the noise)."""
    trials = []
    for (n, noise), values in offsets.items():
        for seed, v in enumerate(values):
            trials.append({"trial": f"lanes_num_cars={n}_lidar_noise={noise}_seed={seed}", "behaviour": "lanes",
                           "seed": seed, "num_cars": n, "lidar_noise": noise, "status": "done", "error": "",
                           "report_episodes": 200, "report_first_seed": REPORT.start, "decisions": 4_800_000,
                           "lanes.majority_share": 1.0, "lanes.time_share_majority": 0.5 + abs(v),
                           "lanes.mean_abs_lane_position": abs(v), "lanes.one_sided_offset": v,
                           "success_rate": 0.9})
    sweep = {"behaviour": "lanes", "grid": {"num_cars": ["8", "4"], "lidar_noise": ["0", "1.0"]}, "seeds": 3,
             "fixed": fixed or {"rounds": "150"}, "timesteps": None, "minutes": None,
             "episodes": 200, "quick": False}
    path.write_text(json.dumps({"sweep": sweep, "trials": trials}))
    return path


def test_lanes_at_other_noise_levels_are_joined_by_the_noise_05_trials_and_compared_by_seed(tmp_path):
    # the noise-0.5 sweep (lidar_noise fixed): one-sided offsets come from the histogram (0.1 per sample bin)
    paper = _lanes(tmp_path / "lanes-paper.json", 150, (8, 4), ([0.991, 0.992, 0.993], [0.61, 0.62, 0.63]))
    # seed by seed, 8 cars drive 0.2 closer to the axis at noise 0 than at 0.5 (a paired fall), and
    # at noise 1.0 one seed keeps left (a negative offset: its size counts)
    offsets = {("8", "0"): [0.05, 0.06, 0.04], ("8", "1.0"): [0.30, -0.35, 0.32],
               ("4", "0"): [0.01, 0.02, 0.03], ("4", "1.0"): [0.02, 0.01, 0.00]}
    noise = _lanes_noise(tmp_path / "lanes-noise01.json", offsets)
    page = tmp_path / "docs" / "results.md"
    assert main([str(paper), str(noise), "--out", str(page)]) == 0
    text = page.read_text()
    mine = text.split("## Lanes at the paper's LiDAR noise levels")[1].split("\n## ")[0]
    at_05 = text.split("## Lanes, at the paper's smallest budget")[1].split("\n## ")[0]
    # the noise 0 / 1.0 trials are only in their own section; the 0.5 rows join it, named as such
    assert "0.325" not in at_05 and "lanes-noise01.json" not in at_05
    assert "lanes-paper.json" in mine and "paired by seed" in mine
    rows = [line for line in mine.splitlines() if re.match(r"\| [48] \| (0|0\.5|1\.0) \| 3 \|", line)]
    assert [r.split(" | ")[:2] for r in rows] == [["| 4", "0"], ["| 4", "0.5"], ["| 4", "1.0"],
                                                  ["| 8", "0"], ["| 8", "0.5"], ["| 8", "1.0"]]
    # the histogram gives every noise-0.5 trial the same offset (its bin centre)
    centre = (LANE_BINS[(len(LANE_BINS) - 1) // 2 + 3] + LANE_BINS[(len(LANE_BINS) - 1) // 2 + 4]) / 2
    diffs = [centre - v for v in offsets[("8", "0")]]
    d = mean_ci(diffs)
    line = next(x for x in mine.splitlines() if x.startswith("- num_cars=8, one-sided offset: noise 0 "))
    assert (f"rises, paired by seed (3 seeds), high minus low noise {d.mean:+.3f} ± {(d.high - d.low) / 2:.3f}, "
            f"p = {t_test_p(diffs, 0.0):.3f}, as in the paper.") in line
    # from 0.5 to 1.0 the paper gives no direction: the lines say what the numbers show, then what it says
    up = next(x for x in mine.splitlines() if x.startswith("- num_cars=8, one-sided offset: noise 0.5 "))
    assert "paper" not in up and "noise 1.0 " + mean_ci([0.30, 0.35, 0.32]).format() in up
    assert "- The paper: past a threshold of noise" in mine
    # 4 against 8 cars at each noise level, the level named
    assert "- crossings on the majority side (lidar_noise=0): num_cars=4" in mine
    assert "- one-sided offset (lidar_noise=1.0): num_cars=4 " in mine and "(num_cars=8, lidar_noise=1.0)" in mine
    # trials of other settings (here more path updates per round) are not joined
    other = _lanes_noise(tmp_path / "lanes-noise01.json", offsets, {"rounds": "150", "spline_updates_per_round": "3"})
    assert main([str(paper), str(other), "--out", str(page)]) == 0
    mine = page.read_text().split("## Lanes at the paper's LiDAR noise levels")[1].split("\n## ")[0]
    assert "lanes-paper.json" not in mine and "| 8 | 0.5 |" not in mine and "| 8 | 1.0 | 3 |" in mine
