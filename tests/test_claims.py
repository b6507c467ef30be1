"""The results page's claims table: each row reads its section's own statements and learning curves."""

import re

import pytest
import shutil
from pathlib import Path

from training.results.claims import (CLAIMS, DIFFERS, NOT_DETECTED, NOT_RUN, OPPOSITE, REPRODUCED, Claim, Reading,
                                     SectionResult, claim_row, combined_verdict, reading_verdict)
from training.results.data import Group
from training.results.rule_parts import LANES_BUDGET
from training.results.sections import SECTIONS
from box2d_driving.metrics.stats import mean_ci

CLAIM = Claim("More noise, fewer violations", ("big", "small"), (Reading(r"- violations: "),), "v", "violations")


def _curves(slopes: dict[str, list[float]]) -> list[dict]:
    """Curve rows at 0..10 M decisions: per noise level, one seed per slope, the metric a line."""
    return [{"lidar_noise": noise, "seed": seed, "decisions": d * 1e6, "v": 0.5 + slope * d}
            for noise, per_seed in slopes.items() for seed, slope in enumerate(per_seed) for d in range(11)]


def _result(lines: list[str], curves=None, seeds=(0, 1, 2), title: str = "Big run") -> SectionResult:
    groups = [Group({"lidar_noise": n}, list(seeds), {"v": mean_ci([0.1] * len(seeds))}) for n in ("0", "1.0")]
    return SectionResult(title, "the paper's 32 M", "16,000,000 decisions", groups, lines, curves, ["lidar_noise"],
                         (16_000_512,) * len(seeds))


def test_a_statement_is_reproduced_opposite_not_detected_or_differs():
    r = Reading(r"- x: ", agrees="as in the paper")
    assert reading_verdict("- x: 0.1 ± 0.02: fewer with noise, as in the paper.", r) == REPRODUCED
    assert reading_verdict("- x: falls, paired by seed (4 seeds), high minus low noise -0.115 ± 0.071, p = 0.014, "
                           "unlike the paper.", r) == OPPOSITE
    assert reading_verdict("- x: 0.1 ± 0.02: no fall detected (p = 0.4); the interval allows a fall of up to 0.026.",
                           r) == NOT_DETECTED
    assert reading_verdict("- x: the intervals overlap: no difference detected.", r) == NOT_DETECTED
    assert reading_verdict("- x: 0.1 ± 0.2: the interval straddles 0.1: neither shown.", r) == NOT_DETECTED
    assert reading_verdict("- x: ours 0.957 ± 0.004 against the paper's 98.45 %: the paper's value lies outside "
                           "our interval; all 3 seeds below it.", r) == DIFFERS
    # a claim of several parts: the first of opposite, differs, not detected that any part has
    assert combined_verdict({REPRODUCED, NOT_DETECTED}) == NOT_DETECTED
    assert combined_verdict({REPRODUCED, DIFFERS, NOT_DETECTED}) == DIFFERS
    assert combined_verdict({OPPOSITE, REPRODUCED, DIFFERS}) == OPPOSITE
    assert combined_verdict({REPRODUCED}) == REPRODUCED and combined_verdict(set()) == NOT_DETECTED


def test_a_row_takes_the_largest_run_that_decides_and_reads_its_curves():
    flat = _curves({"0": [0.0, 0.0005, -0.0005], "1.0": [0.0, 0.0, 0.0]})
    found = {"big": _result(["- violations: no fall detected.", "- other: as in the paper."], flat),
             "small": _result(["- violations: fewer with noise, as in the paper."], title="Small run")}
    words, paper, ours, now, said = claim_row(CLAIM, found)
    assert (words, paper) == ("More noise, fewer violations", "the paper's 32 M")
    assert ours == "[Big run](#big-run): 16.0 M decisions per trial, 3 seeds"
    # a budget in rounds says both; trials not yet finished: the budget asked for
    rounds = SectionResult("R", "", "150 bilevel rounds", found["big"].groups, [], None, [], (4_800_000, 4_832_000))
    assert claim_row(CLAIM, {"big": rounds})[2] == "[R](#r): 4.8 M decisions per trial (150 bilevel rounds), 3 seeds"
    rounds.ran = (4_800_000, 5_900_000)
    assert claim_row(CLAIM, {"big": rounds})[2].startswith("[R](#r): 4.8-5.9 M decisions per trial")
    rounds.ran = ()
    assert claim_row(CLAIM, {"big": rounds})[2] == "[R](#r): 150 bilevel rounds per trial, 3 seeds"
    # in the paper's units: joint steps (our slot-decisions over the cars) and the share of its run's
    lone = SectionResult("L", "", "2,400,000 decisions", found["big"].groups, [], None, [], (2_400_000,),
                         paper_joint_steps=1_920_000, cars=1)
    assert claim_row(CLAIM, {"big": lone})[2] == (
        "[L](#l): 2.4 M decisions per trial = 2.40 M joint steps of 1 car (75.0 epochs of 32,000), 125 % of the "
        "paper's 1.92 M (60 epochs), 3 seeds")
    lone.cars, lone.paper_joint_steps = 4, 2_400_000
    assert "= 0.60 M joint steps of 4 cars (18.8 epochs of 32,000), 25 % of the paper's 2.4 M" in \
        claim_row(CLAIM, {"big": lone})[2]
    assert now == f"**{NOT_DETECTED}**; violations stopped moving at both grid points"
    assert said == "violations: no fall detected."
    # the larger run's trials too few for a statement: the smaller run decides
    found["big"] = _result(["- other: as in the paper."], seeds=(0,))
    words, paper, ours, now, said = claim_row(CLAIM, found)
    assert now == f"**{REPRODUCED}**; violations: no learning curves"
    assert ours.startswith("[Small run](#small-run): ") and said == "violations: fewer with noise, as in the paper."
    # a statement on one training seed (a paper value against a single number) decides nothing either
    found["big"] = _result(["- violations: ours 0.100 (1 seed) against the paper's 98 %: one seed only: no interval."],
                           seeds=(0,))
    assert claim_row(CLAIM, found)[2].startswith("[Small run](#small-run): ")
    # only a run that cannot decide yet: it is shown, undecided, and says why
    del found["small"]
    row = claim_row(CLAIM, found)
    assert row[3].startswith(f"**{NOT_DETECTED}**") and row[4] == "no statement yet (too few seeds for an interval)"
    assert claim_row(CLAIM, {})[2] == "not run yet"
    # no trials in any of its sections: the paper's run and the section that will test it, undecided
    planned = Claim("Lanes", ("lanes-joint", "lanes-paper"), (Reading(r"- x"),), "v", "violations")
    words, paper, ours, now, said = claim_row(planned, {})
    assert (paper, ours, said) == (LANES_BUDGET, "[Lanes with the paper's single 216-way path choice]"
                                   "(#lanes-with-the-papers-single-216-way-path-choice): not run yet", "no trials yet")
    assert now == f"**{NOT_RUN}**"


def test_a_larger_run_that_speaks_to_one_part_of_a_claim_does_not_yet_replace_one_that_speaks_to_all():
    two_parts = Claim("Lanes with 8 cars, none with 4", ("big", "small"),
                      (Reading(r"- offset \(8\b", "one side"), Reading(r"- offset \(4\b", "on the axis")), "v", "v")
    small = _result(["- offset (8): 0.41 ± 0.2: one side.", "- offset (4): 0.33 ± 0.02: one side."], title="Small run")
    found = {"big": _result(["- offset (8): 0.36 ± 0.46: neither shown."], seeds=(0, 1)), "small": small}
    words, paper, ours, now, said = claim_row(two_parts, found)
    assert ours.startswith("[Small run](#small-run): ") and now.startswith(f"**{OPPOSITE}**")
    assert said == "offset (8): 0.41 ± 0.2: one side.<br>offset (4): 0.33 ± 0.02: one side."
    # once the larger run has a statement on both parts, it decides, whatever it says
    found["big"].lines.append("- offset (4): 0.34 ± 0.5: neither shown.")
    words, paper, ours, now, said = claim_row(two_parts, found)
    assert ours.startswith("[Big run](#big-run): ") and now.startswith(f"**{NOT_DETECTED}**")
    # a larger run with a statement on one part, and no smaller run: that part is what it shows
    del found["small"]
    found["big"].lines.pop()
    assert claim_row(two_parts, found)[4] == "offset (8): 0.36 ± 0.46: neither shown."


def test_the_plateau_reading_counts_grid_points_by_verdict():
    # noise 0: every seed still climbs 0.01 per M decisions; noise 1.0: flat
    rising = _curves({"0": [0.01, 0.011, 0.009], "1.0": [0.0, 0.0, 0.0]})
    now = claim_row(CLAIM, {"big": _result(["- violations: as in the paper."], rising)})[3]
    # equal counts keep the grid's order (Counter.most_common lists ties as first met)
    assert now == f"**{REPRODUCED}**; violations still rising at 1 of 2 grid points, stopped moving at 1"
    # noise 0 too noisy: its late changes over the last 5 M decisions are 0.05, -0.05 and 0 (sd 0.05)
    noisy = _curves({"0": [0.01, -0.01, 0.0], "1.0": [0.0, 0.0, 0.0]})
    now = claim_row(CLAIM, {"big": _result(["- violations: as in the paper."], noisy)})[3]
    # t95(k - 1) * 0.05 / sqrt(k) <= 0.02 first at k = 27 (t95(26) = 2.060: 0.0198; k = 26: 0.0202)
    assert now == (f"**{REPRODUCED}**; violations too noisy to tell at 1 of 2 grid points, stopped moving at 1 "
                   "(at the spread of its learning curves, about 27 seeds with curves would narrow its late "
                   "change to ±0.02)")
    one_seed = _curves({"0": [0.0], "1.0": [0.0]})
    now = claim_row(CLAIM, {"big": _result(["- violations: as in the paper."], one_seed)})[3]
    assert now.endswith("violations one seed (no interval) at both grid points")


def test_every_claim_names_real_sections_and_is_decided_by_the_committed_page(tmp_path, monkeypatch):
    """Guards the table against a statement's wording drifting away from its claim's pattern: on the
    committed summaries every claim whose section has trials is decided by at least one line."""
    from training.results.reproduce import default_summaries, load_summary, write_page

    keys = {s.key for s in SECTIONS}
    for claim in CLAIMS:
        assert set(claim.sections) <= keys, claim.words
        assert claim.curve and claim.readings
    root = Path(__file__).resolve().parent.parent
    monkeypatch.chdir(root)
    summaries = [load_summary(p) for p in default_summaries(Path("assets/sweeps"))]
    page, figures = tmp_path / "results.md", tmp_path / "images"
    shutil.copytree(root / "docs" / "images" / "results", figures)
    text = write_page(summaries, page, figures)
    table = text.split("## Where the page stands on the paper's claims")[1].split("\n## ")[0]
    rows = [line for line in table.splitlines() if line.startswith("| ") and not line.startswith("| the paper's")]
    assert len(rows) == len(CLAIMS)
    from training.results.data import groups_of
    from training.results.matching import section_summaries

    ran = {s.key for s in SECTIONS if section_summaries(s, summaries)}
    # sections whose every grid point has one seed so far: no interval, so no statement yet
    single = {s.key for s in SECTIONS if s.key in ran and
              all(len(g.seeds) < 2 for x in section_summaries(s, summaries) for g in groups_of(x, ["success_rate"]))}
    for claim, full in zip(CLAIMS, rows):
        assert full.startswith(f"| {claim.words.replace('|', chr(92) + '|')} |")
        line, arbiter = full.rsplit(" | ", 1)  # our columns, and the paper's own code's
        assert (("([The paper's own code, in its own world]" in arbiter) if claim.arbiter == "noise"
                else ("([The paper's own code on its lone car]" in arbiter or arbiter == "not run there yet |")
                if claim.arbiter == "lone-car" else arbiter == "not run there yet |"), full
        if not ran & set(claim.sections):  # its sweep has no committed trials yet
            assert ": not run yet |" in line and line.endswith("| no trials yet"), line
            continue
        if set(claim.sections) & ran <= single:  # a sweep under way, one seed a point so far
            assert "no statement yet (too few seeds for an interval)" in line, line
            continue
        assert "not run yet" not in line and "no statement yet" not in line, line
        assert re.search(r"\*\*(reproduced|opposite|not detected|differs)\*\*", line)


def test_a_second_reading_is_shown_beside_the_verdict_but_does_not_decide_it():
    claim = Claim("98 % keep the distance", ("big",),
                  (Reading(r"- share ", "lies inside our interval"),
                   Reading(r"- share_moving ", "lies inside our interval", decides=False)), "v", "v")
    lines = ["- share (x): ours 0.95 ± 0.01 against the paper's 98 %: the paper's value lies inside our interval.",
             "- share_moving (x): ours 0.99 ± 0.003 against the paper's 98 %: the paper's value lies outside our "
             "interval."]
    words, paper, ours, now, said = claim_row(claim, {"big": _result(lines)})
    assert now.startswith(f"**{REPRODUCED}**")  # the moving-leader reading differs, but does not decide
    assert "share_moving (x)" in said and "share (x)" in said


def test_holm_adjusts_the_tables_family_of_p_values():
    from training.results.claims import holm, with_holm

    # three tests: 0.01 x 3, 0.04 x 2, 0.30 x 1 (kept non-decreasing)
    assert holm([0.04, 0.01, 0.30]) == pytest.approx([0.08, 0.03, 0.30])
    assert holm([0.5, 0.6]) == pytest.approx([1.0, 1.0])  # capped at 1 and non-decreasing
    rows = [["a", "", "", "", "x: p = 0.010, y: p = 0.040"], ["b", "", "", "", "z: p = 0.300."], ["c", "", "", "", "-"]]
    out = with_holm(rows)
    assert out[0][4] == ("x: p = 0.010 (Holm-adjusted over the table's 3 tests: 0.030), "
                         "y: p = 0.040 (Holm-adjusted over the table's 3 tests: 0.080)")
    assert out[1][4] == "z: p = 0.300 (Holm-adjusted over the table's 3 tests: 0.300)."
    assert out[2] == rows[2] and rows[0][4] == "x: p = 0.010, y: p = 0.040"  # the input is left alone


def test_a_p_value_below_the_printed_digits_is_adjusted_as_a_bound():
    from training.results.claims import with_holm

    # "p < 0.001" is taken as at most 0.001: its adjusted value is a bound, and so is any value
    # the bound carries up the step-down (here 3 x 0.001 against the exact 2 x 0.001)
    rows = [["a", "", "", "", "x: p < 0.001, y: p = 0.001"], ["b", "", "", "", "z: p = 0.200"]]
    out = with_holm(rows)
    assert out[0][4] == ("x: p < 0.001 (Holm-adjusted over the table's 3 tests: < 0.003), "
                         "y: p = 0.001 (Holm-adjusted over the table's 3 tests: < 0.003)")
    assert out[1][4] == "z: p = 0.200 (Holm-adjusted over the table's 3 tests: 0.200)"
    # where an exact value dominates, the bound is exact too
    out = with_holm([["a", "", "", "", "x: p < 0.001, y: p = 0.010"]])
    assert out[0][4] == ("x: p < 0.001 (Holm-adjusted over the table's 2 tests: < 0.002), "
                         "y: p = 0.010 (Holm-adjusted over the table's 2 tests: 0.010)")


def test_the_table_says_which_rows_come_from_the_papers_own_world():
    """The sentence above the claims table names the rows read from ``paper``-preset sections and
    says the rest come from our default world; with none or all, it says so."""
    from training.results.claims import worlds_sentence

    noise, lone = CLAIMS[0], CLAIMS[1]
    assert noise.sections[:2] == ("traffic-lights-paper-left", "traffic-lights-preset")
    assert lone.sections[:3] == ("traffic-lights-paper-turns-1car", "traffic-lights-paper-left-1car",
                                 "traffic-lights-preset-1car")
    says = "- red-light violations: noise 1.0 against 0.25: fewer with noise, as in the paper."
    default_only = {noise.sections[-1]: _result([says])}  # the noise claim read from our default world
    assert worlds_sentence({}).startswith("None of these runs is yet in the paper's own world")
    assert worlds_sentence(default_only).startswith("None of these runs is yet")
    some = worlds_sentence({**default_only, "traffic-lights-preset": _result([says]),
                            "traffic-lights-preset-1car": _result([])})
    assert some.startswith(f"2 of the {len(CLAIMS)} rows are read from runs in the paper's own world")
    assert f"*{noise.words}*; *{lone.words}*; the others from our default world" in some
    assert "the mirror image of that world, on the right" in some  # these sections pin the preset's earlier world


def test_a_lone_car_read_from_the_turning_junction_counts_as_the_papers_world_and_says_which():
    from training.results.claims import worlds_sentence

    lone = CLAIMS[1]
    says = "- 1 car, red-light violations against rule-free scripted drivers: x"
    turning = worlds_sentence({"traffic-lights-paper-turns-1car": _result([says])})
    assert turning.startswith(f"1 of the {len(CLAIMS)} rows are read from runs in the paper's own world")
    assert f"*{lone.words}*" in turning and "`paper-turns` preset" in turning
    assert "`paper-turns`" not in worlds_sentence({"traffic-lights-preset-1car": _result([says])})


def test_the_last_column_shows_the_paper_codes_cell_only_for_the_claims_it_ran():
    from training.results.claims import NOT_RUN_THERE, claims_table

    rows = claims_table({}, {"lone-car": "LONE"})[2:]
    assert len(rows) == len(CLAIMS)
    for claim, line in zip(CLAIMS, rows):
        assert line.endswith("| LONE |" if claim.arbiter == "lone-car" else f"| {NOT_RUN_THERE} |"), line
