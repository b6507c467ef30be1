"""The results page's sections for the paper-settings runs (lights, denser traffic, lanes), from
hand-built summaries and learning curves."""

from __future__ import annotations

import json
import re

from tests.results_helpers import VIOLATIONS, lights_summary
from training.common.seeds import REPORT, SELECTION
from training.evaluation.figure_data import LANE_BINS
from training.results.reproduce import main
from box2d_driving.metrics.stats import mean_ci, t_test_p


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

    grid = lights_summary(tmp_path / "lights.json", VIOLATIONS)
    paper = _paper_lights(tmp_path, {"0.25": [0.111, 0.112, 0.113], "1.0": [0.061, 0.062, 0.063]})
    page = tmp_path / "docs" / "results.md"
    assert main([str(grid), str(paper), "--out", str(page)]) == 0
    text = page.read_text()
    mine = text.split("## Stopping at red lights, the noise grid at 2.4 M decisions")[1].split("\n## ")[0]
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
                    w.writerow({"trial": f"lights_lidar_noise={noise}_seed={seed}", "seed": seed,
                                "lidar_noise": noise, "decisions": d,
                                "agent_steps": d * 0.7, "episodes": 100, "first_seed": SELECTION.start,
                                "success_rate": 0.9, "collision_rate": 0.1, "red_light_violation_rate": v})
    assert main([str(grid), str(paper), "--out", str(page)]) == 0
    mine = page.read_text().split("## Stopping at red lights, the noise grid at 2.4 M decisions")[1].split("\n## ")[0]
    assert "the learning curves below" in mine and f"selection seeds from {SELECTION.start:,}" in mine
    line = next(x for x in mine.splitlines() if x.startswith("- red-light violations, change over the last 50 %"))
    assert "the last 1.28 M decisions" in line
    assert "lidar_noise 0.25 0.000 ± 0.000 (stopped moving)" in line
    # noise 1.0 falls 0.020-0.022 per 320,000 decisions: over the last 1.28 M, 4 of those steps
    falls = mean_ci([-(0.02 + 0.001 * s) * 4 for s in range(3)])
    assert f"lidar_noise 1.0 {falls.format()} (still falling)" in line
    assert (tmp_path / "docs" / "images" / "results" / "traffic-lights-paper_curves.png").stat().st_size > 10_000
    assert "of the 6 finished trials" not in mine  # the curves cover every finished trial
    # a trial carried part-way has curve rows but no summary row yet: the page reads finished trials only
    with open(tmp_path / "curves" / "lights-paper.csv", "a", newline="") as f:
        w = csv.writer(f)
        for k in range(1, 5):
            w.writerow(["lights_lidar_noise=0.25_seed=3", 3, "0.25", 320_000 * k, 0, 100, SELECTION.start,
                        0.9, 0.1, 0.9 - 0.2 * k])
    before = page.read_text()
    assert main([str(grid), str(paper), "--out", str(page)]) == 0
    assert page.read_text() == before
    # curves of only some trials (the others finished on a machine that kept no checkpoints) say which
    path = tmp_path / "curves" / "lights-paper.csv"
    lines = path.read_text().splitlines()
    path.write_text("\n".join(x for x in lines if "noise=1.0_seed=2," not in x) + "\n")
    assert main([str(grid), str(paper), "--out", str(page)]) == 0
    mine = page.read_text().split("## Stopping at red lights, the noise grid at 2.4 M decisions")[1].split("\n## ")[0]
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
    mine = text.split("## Lanes, 4.8 M decisions (150 rounds)")[1].split("\n## ")[0]
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
                    w.writerow({"trial": f"lanes_num_cars={n}_seed={seed}", "seed": seed, "num_cars": n, "decisions": d,
                                "agent_steps": d // 2, "episodes": 100, "first_seed": SELECTION.start,
                                "success_rate": 0.9, "collision_rate": 0.1, "red_light_violation_rate": 0.1,
                                "lanes.majority_share": 1.0, "lanes.time_share_majority": 1.0,
                                "lanes.mean_abs_lane_position": 0.3,
                                "lanes.one_sided_offset": 0.3 if n == 8 else 0.1 + 0.01 * k})
    assert main([str(short), str(paper), "--out", str(page)]) == 0
    mine = page.read_text().split("## Lanes, 4.8 M decisions (150 rounds)")[1].split("\n## ")[0]
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
    theirs = text.split("## Lanes, 4.8 M decisions (150 rounds)")[1].split("\n## ")[0]
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
    at_05 = text.split("## Lanes, 4.8 M decisions (150 rounds)")[1].split("\n## ")[0]
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


def _preset_lights(path, fixed, grid, violations):
    """A lights sweep in the paper's world and network (``--preset paper``, the paper code's LiDAR
    encoder), 4 cars: ``violations`` per noise level
    (seeds 0-2); ``fixed``: its fixed options besides cars and preset; ``grid``: its noise grid."""
    trials = [{"trial": f"lights_lidar_noise={noise}_seed={seed}", "behaviour": "lights", "seed": seed,
               **({"lidar_noise": noise} if grid else {}), "status": "done", "error": "",
               "report_episodes": 200, "report_first_seed": REPORT.start, "decisions": 9_600_000,
               "env_config.num_cars": 4, "red_light_violation_rate": v, "success_rate": 0.95, "collision_rate": 0.05}
              for noise, values in violations.items() for seed, v in enumerate(values)]
    sweep = {"behaviour": "lights", "grid": {"lidar_noise": list(violations)} if grid else {}, "seeds": 3,
             "fixed": {"num_cars": "4", "preset": "paper", "lidar_encoder": "original", **fixed}, "timesteps": None,
             "minutes": None,
             "episodes": 200, "quick": False}
    path.write_text(json.dumps({"sweep": sweep, "trials": trials}))
    return path


def test_the_paper_world_grid_is_joined_by_its_noise_1_sweep_at_its_own_budget(tmp_path):
    grid = _preset_lights(tmp_path / "lights-preset.json", {"original_epochs": "75"}, True,
                          {"0.25": [0.10, 0.12, 0.11], "0.5": [0.08, 0.09, 0.07], "0.75": [0.06, 0.05, 0.07]})
    noise1 = _preset_lights(tmp_path / "lights-preset-noise1.json", {"original_epochs": "50", "lidar_noise": "1.0"},
                            False, {"1.0": [0.02, 0.03, 0.01]})
    page = tmp_path / "docs" / "results.md"
    assert main([str(grid), str(noise1), "--out", str(page)]) == 0
    text = page.read_text()
    mine = text.split("## Stopping at red lights in the paper's world, update and network\n")[1].split("\n## ")[0]
    assert "75 epochs of 32,000 joint steps (2.4 M joint steps) per trial" in mine
    rows = [line.split(" | ")[0] for line in mine.splitlines() if re.match(r"\| (0\.25|0\.5|0\.75|1\.0) \| 3 \|", line)]
    assert rows == ["| 0.25", "| 0.5", "| 0.75", "| 1.0"]  # the 50-epoch noise-1.0 trials join as a row
    assert "lights-preset-noise1.json" in mine
    line = next(x for x in mine.splitlines() if x.startswith("- 4 cars, red-light violations: noise 0.25 "))
    assert "paired by seed (3 seeds)" in line and line.endswith("as in the paper.")
    # the claim is read from the paper-world section now that it has trials
    claims = text.split("## Where the page stands on the paper's claims")[1].split("\n## ")[0]
    row = next(x for x in claims.splitlines() if x.startswith("| With more LiDAR noise"))
    assert "[Stopping at red lights in the paper's world, update and network]" in row and "**reproduced**" in row
    assert "100 % of the paper's 2.4 M" in row
    # a noise-1.0 sweep at another budget than the one joins_differ allows to differ is not joined
    other = _preset_lights(tmp_path / "lights-preset-noise1.json", {"original_epochs": "50", "lidar_noise": "1.0",
                                                                     "ent_coef": "0.01"}, False,
                           {"1.0": [0.02, 0.03, 0.01]})
    assert main([str(grid), str(other), "--out", str(page)]) == 0
    title = "## Stopping at red lights in the paper's world, update and network\n"
    mine = page.read_text().split(title)[1].split("\n## ")[0]
    assert not re.search(r"^\| 1\.0 \| 3 \|", mine, re.M)


def test_the_grid_in_the_preset_as_it_is_now_has_its_own_sections_before_the_mirror_images(tmp_path):
    """A preset sweep that recorded the paper code's side and readings is shown in the left-hand
    sections and decides the noise claim there; one of the earlier world stays in its own."""
    now = {"drive_on": "left", "arrived_heading_error": "minus_heading", "goal_distance": "straight",
           "light_view": "axis_point"}
    grid = _preset_lights(tmp_path / "lights-paper-left.json", {"original_epochs": "75", **now}, True,
                          {"0.25": [0.10, 0.12, 0.11], "0.5": [0.08, 0.09, 0.07], "0.75": [0.06, 0.05, 0.07]})
    noise1 = _preset_lights(tmp_path / "lights-paper-left-noise1.json",
                            {"original_epochs": "50", "lidar_noise": "1.0", **now}, False, {"1.0": [0.02, 0.03, 0.01]})
    before = _preset_lights(tmp_path / "lights-preset.json", {"original_epochs": "75"}, True,
                            {"0.25": [0.30, 0.32, 0.31], "0.5": [0.28, 0.29, 0.27]})
    page = tmp_path / "docs" / "results.md"
    assert main([str(grid), str(noise1), str(before), "--out", str(page)]) == 0
    text = page.read_text()
    left = text.split("## Stopping at red lights in the paper's own world, update and network (on the left)\n")[1]
    left = left.split("\n## ")[0]
    assert "lights-paper-left.json" in left and "lights-preset.json" not in left
    rows = [line.split(" | ")[0] for line in left.splitlines() if re.match(r"\| (0\.25|0\.5|0\.75|1\.0) \| 3 \|", line)]
    assert rows == ["| 0.25", "| 0.5", "| 0.75", "| 1.0"]  # its noise-1.0 sweep joins it
    assert "due west -pi" in left and "mirror image" not in left.split("**Budget.**")[0]
    mirror = text.split("## Stopping at red lights in the paper's world, update and network\n")[1].split("\n## ")[0]
    assert "lights-preset.json" in mirror and "lights-paper-left.json" not in mirror
    claims = text.split("## Where the page stands on the paper's claims")[1].split("\n## ")[0]
    row = next(x for x in claims.splitlines() if x.startswith("| With more LiDAR noise"))
    assert "[Stopping at red lights in the paper's own world, update and network (on the left)]" in row


def _drop_fixed(path, key):
    """``path``'s summary without the fixed option ``key`` (a sweep that left it to its preset)."""
    summary = json.loads(path.read_text())
    del summary["sweep"]["fixed"][key]
    path.write_text(json.dumps(summary))
    return path


def test_a_preset_sweep_is_shown_only_where_its_presets_settings_match(tmp_path, capsys):
    title = "## Stopping at red lights in the paper's world, update and network\n"
    # no lidar_encoder given: it ran with the preset's (the paper code's), so it is that section's
    grid = _drop_fixed(_preset_lights(tmp_path / "lights-preset.json", {"original_epochs": "75"}, True,
                                      {"0.25": [0.10, 0.12, 0.11], "0.5": [0.08, 0.09, 0.07]}), "lidar_encoder")
    page = tmp_path / "docs" / "results.md"
    assert main([str(grid), "--out", str(page)]) == 0
    text = page.read_text()
    assert "lights-preset.json" in text.split(title)[1].split("\n## ")[0]
    ours = text.split("## Stopping at red lights, the noise grid at 2.4 M decisions\n")[1].split("\n## ")[0]
    assert "Not run yet" in ours  # a preset's world is not our default world's section
    assert "warning" not in capsys.readouterr().err
    # 2 cars: no section of the paper's world has it, and our world's sections do not take it
    two = json.loads(grid.read_text())
    two["sweep"]["fixed"]["num_cars"] = "2"
    (tmp_path / "two.json").write_text(json.dumps(two))
    assert main([str(tmp_path / "two.json"), "--out", str(page)]) == 0
    assert "two.json measures no rule of the page" in capsys.readouterr().err
    assert "two.json" not in page.read_text()


def test_our_worlds_sections_hold_runs_of_our_encoder_only(tmp_path, capsys):
    """A summary of before the encoder was recorded ran ours and stays in its section; the same
    sweep run with today's default (the paper code's encoder, recorded) is no run of that section."""
    old = _paper_lights(tmp_path, {"0.25": [0.10, 0.12, 0.11], "1.0": [0.08, 0.09, 0.07]})
    page = tmp_path / "docs" / "results.md"
    title = "## Stopping at red lights, the noise grid at 2.4 M decisions\n"
    assert main([str(old), "--out", str(page)]) == 0
    assert "lights-paper.json" in page.read_text().split(title)[1].split("\n## ")[0]
    today = json.loads(old.read_text())
    today["sweep"]["fixed"]["lidar_encoder"] = "original"
    (tmp_path / "today.json").write_text(json.dumps(today))
    assert main([str(tmp_path / "today.json"), "--out", str(page)]) == 0
    assert "Not run yet" in page.read_text().split(title)[1].split("\n## ")[0]
    assert "today.json measures no rule of the page" in capsys.readouterr().err
