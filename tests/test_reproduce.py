"""``box2d-driving reproduce``: the results page and README table from small hand-built sweep
summaries, and ``reproduce --run``."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from tests.results_helpers import VIOLATIONS, lights_summary, ragged_tables
from training.common.seeds import REPORT, SELECTION
from training.results.reproduce import ResultsError, main, trial_budget
from box2d_driving.metrics.stats import mean_ci


def test_page_shows_means_intervals_seeds_statements_and_the_figure(tmp_path):
    summary = lights_summary(tmp_path / "lights.json", VIOLATIONS,
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
    summary = lights_summary(tmp_path / "s.json", VIOLATIONS, first_seed=SELECTION.start)
    assert main([str(summary), "--out", str(tmp_path / "r.md")]) == 2
    assert "not on report seeds" in capsys.readouterr().err and not (tmp_path / "r.md").exists()
    (tmp_path / "junk.json").write_text("{}")
    with pytest.raises(ResultsError):
        from training.results.reproduce import load_summary
        load_summary(tmp_path / "junk.json")


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

    summary = lights_summary(tmp_path / "lights.json", VIOLATIONS)
    section = next(s for s in reproduce.SECTIONS if s.summary_name == "lights")
    assert section.seeds == 3
    more = dataclasses.replace(section, command=section.command.replace("--seeds 3", "--seeds 4"))
    monkeypatch.setattr(reproduce, "SECTIONS", tuple(more if s is section else s for s in reproduce.SECTIONS))
    page = tmp_path / "results.md"
    assert main([str(summary), "--out", str(page)]) == 0
    assert "12 of 16 planned trials done" in page.read_text()


def test_a_sweep_with_no_finished_trial_shows_no_empty_table(tmp_path):
    """Trials carried part-way or pending only: the section says none has finished, with no table
    header over no rows and no count of kept weights."""
    statuses = {f"lights_lidar_noise={n}_num_cars={c}_seed={s}": ("stopped" if s == 0 else "pending")
                for (n, c) in VIOLATIONS for s in range(3)}
    summary = lights_summary(tmp_path / "lights.json", VIOLATIONS, statuses=statuses)
    page = tmp_path / "results.md"
    assert main([str(summary), "--out", str(page)]) == 0
    text = page.read_text()
    part = text[text.index("**Ours** (0 of 12 planned trials done"):]
    part = part[:part.index("\n## ")]
    assert "No trial has finished yet" in part and "final weights kept" not in part
    assert "| lidar_noise | num_cars | seeds |" not in part
    assert "`lights_lidar_noise=0_num_cars=1_seed=0` (stopped)" in part


def test_a_trial_carried_part_way_is_named_with_how_far_it_got(tmp_path):
    """A trial stopped part-way and carried beside the summary is named under its section's table
    with its decisions against its budget (from the carried run's own files); a finished trial's
    leftover carry is not; an unreadable carry is an error naming it."""
    import json

    from training.results.data import ResultsError
    from training.results.notes import carried_line

    statuses = {f"lights_lidar_noise={n}_num_cars={c}_seed={s}": ("stopped" if (s, c) == (0, "1") else "done")
                for (n, c) in VIOLATIONS for s in range(3)}
    summary = lights_summary(tmp_path / "lights.json", VIOLATIONS, statuses=statuses)
    for trial, ran in (("lights_lidar_noise=0_num_cars=1_seed=0", 5_000),
                       ("lights_lidar_noise=0_num_cars=4_seed=0", 20_480)):
        run = tmp_path / "carried" / "lights" / trial
        run.mkdir(parents=True)
        (run / "state.json").write_text(json.dumps({"decisions": ran}))
        (run / "config.json").write_text(json.dumps({"timesteps": 20_000}))
    page = tmp_path / "results.md"
    assert main([str(summary), "--out", str(page)]) == 0
    text = page.read_text()
    assert "`lights_lidar_noise=0_num_cars=1_seed=0` at 5,000 of 20,000 (25 %) decisions." in text
    assert "num_cars=4_seed=0` at" not in text  # done: its carry is a leftover, not a trial part-way

    loaded = {"path": str(summary), "trials": [{"trial": t, "status": st} for t, st in statuses.items()]}
    (tmp_path / "carried" / "lights" / "lights_lidar_noise=0_num_cars=1_seed=0" / "state.json").write_text("{")
    with pytest.raises(ResultsError, match="num_cars=1_seed=0: a carried run"):
        carried_line(loaded)


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


def test_each_rule_runs_with_the_resources_its_command_names_unless_overridden():
    """The trials' torch threads follow --cpus-per-trial, and trials retrace each other only under
    the same threads: a rule continued by reproduce --run must run as the command on its page."""
    from training.results.run_all import sweep_resources
    from training.results.sections import SECTIONS

    by_key = {s.key: s for s in SECTIONS}
    # its command: --cpus-per-trial 2 --max-concurrent 1
    assert sweep_resources(by_key["communication-paper-32M"]) == (2, 1)
    assert sweep_resources(by_key["traffic-lights"]) == (1, None)  # names neither: the sweep's defaults
    assert sweep_resources(by_key["communication-paper-32M"], 4, None) == (4, 1)
    assert sweep_resources(by_key["traffic-lights"], None, 3) == (1, 3)


@pytest.mark.e2e
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
        from training.sweeps.carry import carry_run

        name = "lights_num_cars=2_seed=0"
        saved = carry_run(Path(next(r for r in first if r["trial"] == name)["run"]), tmp_path / "saved" / name)
        shutil.rmtree(runs)
        assert reproduce.main(argv) == 0
        assert not list((runs / "sweep-tiny" / "tune").glob("*/checkpoint_*"))
        again = json.loads((folder / "tiny.json").read_text())["trials"]
        key = lambda rows: {r["trial"]: (r["success_rate"], r["red_light_violation_rate"], r["run"]) for r in rows}  # noqa: E731
        assert key(again) == key(first)
        assert (folder / "curves" / "tiny.csv").read_text() == curves  # kept: no run folder here to redraw them

        # a trial carried from a machine that went away before it landed: continued from its
        # carried run (here it had reached its budget: evaluated, not trained again); the carry
        # goes once the trial lands, the curve drawn before the carry stays
        kept = json.loads((folder / "tiny.json").read_text())
        kept["trials"] = [r for r in kept["trials"] if r["trial"] != name]
        (folder / "tiny.json").write_text(json.dumps(kept))
        shutil.copytree(saved, folder / "carried" / "tiny" / name)
        shutil.rmtree(runs)
        assert reproduce.main(argv) == 0
        rows = {r["trial"]: r for r in json.loads((folder / "tiny.json").read_text())["trials"]}
        assert rows[name]["status"] == "done" and rows[name]["decisions"] == 160
        assert rows[name]["success_rate"] == key(first)[name][0]  # the same policy on the same report seeds
        continued = Path(rows[name]["run"])
        assert json.loads((continued / "state.json").read_text()) == json.loads((saved / "state.json").read_text())
        assert not (folder / "carried" / "tiny" / name).exists()
        assert (folder / "curves" / "tiny.csv").read_text() == curves
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
    # a carried run that is not one of the sweep's trials: refused before training too
    (folder / "carried" / "tiny" / "lights_num_cars=9_seed=0").mkdir(parents=True)
    code = reproduce.main(["--run", "--summaries", str(folder), "--runs", str(tmp_path / "runs"),
                           "--out", str(tmp_path / "results.md")])
    err = capsys.readouterr().err
    assert code == 2 and "lights_num_cars=9_seed=0 is not a trial of this sweep" in err, err
    assert not (tmp_path / "runs").exists()
    with pytest.raises(SystemExit) as exit_:
        reproduce.main(["--only", "traffic-lights"])  # without --run
    assert exit_.value.code == 2 and "--only goes with --run" in capsys.readouterr().err


def test_a_time_limit_goes_with_run_is_positive_and_starts_no_sweep_once_passed(tmp_path, monkeypatch, capsys):
    import time

    from training.results import reproduce
    from tests.helpers import raised_in_a_thread
    from training.results.run_all import ReproduceError, run_sections
    from training.sweeps.deadline import Deadline

    monkeypatch.setattr(reproduce, "SECTIONS", (_tiny_section(),))
    with pytest.raises(SystemExit) as exit_:
        reproduce.main(["--time-limit", "30"])
    assert exit_.value.code == 2 and "--time-limit goes with --run" in capsys.readouterr().err
    code = reproduce.main(["--run", "--time-limit", "0", "--summaries", str(tmp_path / "sweeps"),
                           "--runs", str(tmp_path / "runs"), "--out", str(tmp_path / "results.md")])
    assert code == 2 and "--time-limit: 0.0 is not a positive number of minutes" in capsys.readouterr().err
    assert not (tmp_path / "runs").exists() and not (tmp_path / "results.md").exists()
    # past the limit before a rule's sweep starts: it does not start, and the run says how to go on
    code = run_sections(reproduce.SECTIONS, tmp_path / "sweeps", tmp_path / "runs",
                        deadline=Deadline(time.monotonic() - 1.0))
    out = capsys.readouterr().out
    assert code == 1 and "not started, --time-limit reached" in out and not (tmp_path / "runs").exists()
    # outside the main thread the limit could never stop the run: refused before anything is written
    caught = raised_in_a_thread(lambda: run_sections(reproduce.SECTIONS, tmp_path / "sweeps", tmp_path / "runs",
                                                     deadline=Deadline(time.monotonic() + 60)))
    assert len(caught) == 1 and isinstance(caught[0], ReproduceError) and "main thread" in str(caught[0])
    assert not (tmp_path / "runs").exists()


@pytest.mark.e2e
def test_a_time_limit_reached_mid_trial_carries_the_trial_with_its_curve_so_far(tmp_path, monkeypatch):
    """A real sweep stopped by its deadline: here the deadline "passes" once the trial in training
    has reported its first checkpoint (a time in minutes would make the test depend on this
    machine's speed), and the run then does what it does on Ctrl-C: the trial is carried with its
    curve so far, it has no summary row yet, and the command says how to go on."""
    import dataclasses

    import ray

    from training.results.run_all import run_sections
    from training.sweeps import curves
    from training.sweeps.deadline import Deadline

    class AtFirstCheckpoint(Deadline):
        def passed(self) -> bool:
            return any(p.read_text().strip() for p in (tmp_path / "runs").glob("sweep-tiny/tune/*/result.json"))

        def left_s(self) -> float:
            return -1.0 if self.passed() else 3600.0

    tiny = _tiny_section()
    long = dataclasses.replace(tiny, command=tiny.command.replace("--grid num_cars=1,2", "--grid num_cars=2")
                               .replace("--timesteps 160", "--timesteps 2000000"))
    monkeypatch.setattr(curves, "SWEEP_CURVE_EPISODES", 2)
    folder = tmp_path / "sweeps"
    deadline = AtFirstCheckpoint(end=0.0, poll_s=0.2)
    try:
        assert run_sections([long], folder, tmp_path / "runs", max_concurrent=1, deadline=deadline) == 1
    finally:
        ray.shutdown()
    assert deadline.fired
    name = "lights_num_cars=2_seed=0"
    carried = folder / "carried" / "tiny" / name
    state = json.loads((carried / "state.json").read_text())
    assert 0 < state["decisions"] < 2_000_000
    rows = [r for r in (folder / "curves" / "tiny.csv").read_text().splitlines()[1:] if r.startswith(name + ",")]
    assert rows  # the curve so far, drawn before the carry
    assert json.loads((folder / "tiny.json").read_text())["trials"] == []  # nothing finished: no row to commit


def test_readme_table_shows_each_rules_headline_over_seeds_and_links_its_section(tmp_path, capsys):
    from training.results.readme import README_END, README_START

    summary = lights_summary(tmp_path / "lights.json", {**VIOLATIONS, ("0.5", "4"): [0.05, 0.07]})
    readme = tmp_path / "README.md"
    readme.write_text(f"# Title\n\nbefore\n{README_START}\nold table\n{README_END}\nafter\n")
    page = tmp_path / "docs" / "results.md"
    assert main([str(summary), "--out", str(page), "--readme", str(readme)]) == 0
    text = readme.read_text()
    assert text.startswith("# Title\n\nbefore\n") and text.endswith(f"{README_END}\nafter\n")
    assert "old table" not in text
    row = next(line for line in text.splitlines() if line.startswith("| stop at red lights |"))
    # two seeds: the t-interval reaches below 0, so it is cut at the share's range
    assert f"red-light violations {mean_ci([0.05, 0.07], bounds=(0.0, 1.0)).format()}" in row and "| 2 |" in row
    assert "red-light violations 0.060 [0.000, " in row
    assert "(docs/results.md#stopping-at-red-lights)" in row
    # the README shows the few rows marked for it; the page shows every headline, linked within it
    assert "| lone car ignores" not in text and "| lanes emerge |" not in text
    assert "| lanes, 16 M decisions |" in text and "not run yet | 0 |" in text
    glance = page.read_text().split("## Every headline at a glance")[1].split("\n## ")[0]
    lone = next(line for line in glance.splitlines() if line.startswith("| lone car ignores"))
    assert f"red-light violations {mean_ci([0.30, 0.35, 0.40]).format()}" in lone and "| 3 |" in lone
    assert "| lanes emerge |" in glance and "not run yet | 0 | [Lanes](#lanes)" in glance

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

    from training.results.readme import README_END, README_START, readme_table
    from training.results.reproduce import default_summaries, load_summary, write_page

    root = Path(__file__).resolve().parent.parent
    monkeypatch.chdir(root)
    summaries = [load_summary(p) for p in default_summaries(Path("assets/sweeps"))]
    readme = (root / "README.md").read_text()
    assert readme.split(README_START + "\n")[1].split("\n" + README_END)[0] == readme_table(summaries)
    assert not ragged_tables(readme) and not ragged_tables((root / "docs" / "results.md").read_text())
    page, figures = tmp_path / "docs" / "results.md", tmp_path / "docs" / "images" / "results"
    shutil.copytree(root / "docs" / "images" / "results", figures)  # the animations are linked, not drawn
    assert write_page(summaries, page, figures) == (root / "docs" / "results.md").read_text()


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

    assert ("The paper's runs: 8 cars, all junctions, entropy 1e-4, 1,000 epochs of 32,000 joint steps (32 M joint "
            "steps: up to 256 M car-decisions, fewer as arrived cars leave).") in budget_note(section("right-of-way"))
    assert "not known to us" in budget_note(section("fast-lanes"))
    from training.results.sections import SECTIONS

    assert all("stopped moving" in budget_note(s) for s in SECTIONS)


def test_seeds_added_after_an_interim_look_are_marked():
    from training.results.reproduce import ADDED_MARK, _estimate_cell
    from box2d_driving.metrics.stats import mean_ci

    e = mean_ci([0.1, 0.2, 0.3, 0.4])
    assert _estimate_cell(e, [0, 1, 2, 3], planned=3).endswith(f"(0.100, 0.200, 0.300, 0.400{ADDED_MARK})")
    assert ADDED_MARK not in _estimate_cell(e, [0, 1, 2, 3], planned=None)
    assert ADDED_MARK not in _estimate_cell(e, [0, 1, 2], planned=1)  # values and seeds do not line up: no marks


@pytest.mark.parametrize("folder", ["missing", "empty"])
def test_a_page_is_never_written_from_no_summaries(tmp_path, capsys, folder):
    from training.results import reproduce

    (tmp_path / "empty").mkdir()
    page = tmp_path / "results.md"
    page.write_text("the committed page")
    code = reproduce.main(["--summaries", str(tmp_path / folder), "--out", str(page)])
    assert code == 2 and "no s" in capsys.readouterr().err
    assert page.read_text() == "the committed page"


def test_the_claims_tables_budget_is_in_the_originals_units_too():
    """Our largest run beside the paper's, in decisions, joint steps and the original's epochs of
    32,000 joint steps (our slot-decisions are joint steps x cars)."""
    from training.results.claims import SectionResult, _budget

    result = SectionResult("Denser traffic", "500 epochs", "16,000,000 decisions", [], [], None, [],
                           ran=(16_000_000,), paper_joint_steps=16_000_000, cars=8)
    assert _budget(result) == ("16.0 M decisions per trial = 2.00 M joint steps of 8 cars (62.5 epochs of 32,000), "
                               "12 % of the paper's 16 M (500 epochs)")
