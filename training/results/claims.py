"""Where the results page stands on the paper's claims: one table at the top of docs/results.md,
a row per claim the page tests at the paper's own settings, saying "reproduced", "opposite", "not
detected" or "differs" at the largest budget run so far, and whether the claim's metric had stopped
moving there.

Nothing here judges a number: a row reads the statements its section already printed (each says
"as in the paper", "unlike the paper", "no ... detected" or "neither shown" in its own words) and the section's
learning curves through :func:`training.results.curves.plateau_verdict`, so the table can never
disagree with the sections below it.
"""

from __future__ import annotations

import re
from collections import Counter
from dataclasses import dataclass
from typing import Any, Mapping, Optional

from training.results.curves import (PLATEAU_TOLERANCE, TOO_NOISY, late_changes, plateau_verdict, seeds_to_settle,
                                     settle_words)
from training.results.data import Group
from training.results.deviations import PaperCommand, deviations, section_settings
from training.common.markdown import all_of, anchor, row, separator
from training.original.commands import TrainerSettings
from training.results.sections import section
from box2d_driving.metrics.stats import ONE_SEED

__all__ = ["CLAIMS", "Claim", "Reading", "SectionResult", "claim_row", "claims_part", "claims_table",
           "combined_verdict", "reading_verdict"]

# the verdicts, one rule for all (stated once, in the page's legend): the effect shown in the
# paper's direction or the paper's value inside our interval; the effect shown the other way; no
# effect shown either way; a value of the paper's that our interval excludes
REPRODUCED, OPPOSITE, NOT_DETECTED, DIFFERS = "reproduced", "opposite", "not detected", "differs"
NOT_RUN = "not run yet"
# how a claim of several parts is decided: the first of these any part has, else reproduced
PRECEDENCE = (OPPOSITE, DIFFERS, NOT_DETECTED)


@dataclass(frozen=True)
class Reading:
    """The statements of a section that decide a claim: every line matching ``pattern`` (a regular
    expression matched at the line's start), which agrees with the paper when it contains
    ``agrees`` and says nothing either way when it contains "neither shown"."""

    pattern: str
    agrees: str = "as in the paper"
    decides: bool = True  # False: shown beside the claim (another reading of its definition), not judged


@dataclass(frozen=True)
class Claim:
    """One of the paper's claims. ``sections``: the page's sections that test it, the largest
    budget first (the first that has trials decides); ``curve``: the metric (a learning-curve
    column) whose late change says whether the claim's measure had stopped moving."""

    words: str
    sections: tuple[str, ...]
    readings: tuple[Reading, ...]
    curve: str
    curve_label: str
    # the cell of the paper's own trainer, where it ran the claim: "noise" (training/results/arbiter.py),
    # "lone-car" (training/results/lone_car_arbiter.py); "" none
    arbiter: str = ""
    # the paper's command for it, against which the row lists what its run did differently
    command: Optional[PaperCommand] = None


@dataclass
class SectionResult:
    """What the page found for one section: its title, the paper's run, our per-trial budget in
    words, its grid points, the statements printed under its table, its learning curves (None
    where none are committed), the grid's keys and the decisions its finished trials ran."""

    title: str
    paper_budget: str
    budget: str
    groups: list[Group]
    lines: list[str]
    curves: Optional[list[dict[str, Any]]]
    keys: list[str]
    ran: tuple[int, ...] = ()
    paper_joint_steps: int = 0
    cars: int = 0


def _budget(result: SectionResult) -> str:
    """Decisions per trial as run (millions), with the budget asked for where it was not decisions."""
    if not result.ran:
        return f"{result.budget} per trial"
    low, high = min(result.ran) / 1e6, max(result.ran) / 1e6
    ran = f"{low:.1f} M" if f"{low:.1f}" == f"{high:.1f}" else f"{low:.1f}-{high:.1f} M"
    asked = "" if "decisions" in result.budget else f" ({result.budget})"
    share = ""
    if result.paper_joint_steps and result.cars:  # our slot-decisions are joint steps x cars
        joint, epoch = max(result.ran) / result.cars, TrainerSettings.steps_per_epoch
        cars = f"{result.cars} car" + ("s" if result.cars != 1 else "")
        share = (f" = {joint / 1e6:.2f} M joint steps of {cars} ({joint / epoch:.1f} epochs of "
                 f"{epoch:,}), {100 * joint / result.paper_joint_steps:.0f} % of the paper's "
                 f"{result.paper_joint_steps / 1e6:g} M ({result.paper_joint_steps / epoch:,g} epochs)")
    return f"{ran} decisions per trial{asked}{share}"


# "lanes with 8 cars, none with 4": whether each car count keeps to one side (both lanes sections)
LANES_READINGS = (Reading(r"- one-sided offset \(num_cars=8\b", "the cars keep to one side"),
                  Reading(r"- one-sided offset \(num_cars=4\b", "the cars drive on the axis or on both sides"),
                  # beside it: each car count against drivers with no lane rule on random paths
                  Reading(r"- one-sided offset against scripted drivers ", "learnt", decides=False))

# the lanes and nuScenes commands, whose lines the experiment list left empty: its entropy for
# every lane and nuScenes run (1e-4); where training started, not stated
LANES_COMMAND = PaperCommand(1e-4, start=None)
NUSCENES_COMMAND = PaperCommand(1e-4, start=None, maps="nuScenes junctions")

CLAIMS: tuple[Claim, ...] = (
    Claim("With more LiDAR noise, fewer cars enter on red",
          ("traffic-lights-paper-left", "traffic-lights-preset", "traffic-lights-paper"),
          (Reading(r"- 4 cars, red-light violations: "),
           Reading(r"- red-light violations against scripted drivers ", decides=False)),
          "red_light_violation_rate", "red-light violations", arbiter="noise", command=PaperCommand(1e-4)),
    # a lone car has no car to see: the runs with our (often dead) LiDAR encoder still speak to it
    Claim("A lone car has no need to follow the light",
          ("traffic-lights-paper-turns-1car", "traffic-lights-paper-left-1car", "traffic-lights-preset-1car",
           "traffic-lights-preset-relu-1car"),
          (Reading(r"- 1 car, red-light violations against rule-free scripted drivers "),
           # beside it: the lone car against the 4-car row of the same world, budget and noise
           Reading(r"- red-light violations: these trials", decides=False)),
          "red_light_violation_rate", "red-light violations", arbiter="lone-car",
          command=PaperCommand(1e-3)),
    Claim("With more cars, fewer cars enter on red",
          ("traffic-lights-paper-left-8cars", "traffic-lights-preset-8cars", "denser-traffic-paper"),
          (Reading(r"- red-light violations: these trials"),), "red_light_violation_rate", "red-light violations",
          command=PaperCommand(1e-4, start="from its 4-car noise-0 model, actor and critic")),
    Claim("Lanes with 8 cars, none with 4", ("lanes-paper-16M", "lanes-noise", "lanes-paper"),
          LANES_READINGS,
          "lanes.one_sided_offset", "one-sided offset", command=LANES_COMMAND),
    Claim("Lanes with 8 cars, none with 4, the path picked as in the paper's code (one 216-way softmax)",
          ("lanes-joint",),
          LANES_READINGS,
          "lanes.one_sided_offset", "one-sided offset", command=LANES_COMMAND),
    Claim("Lanes more consistent with LiDAR noise than with perfect perception", ("lanes-noise",),
          (Reading(r"- num_cars=\d+, one-sided offset: noise 0 "),), "lanes.one_sided_offset", "one-sided offset",
          command=LANES_COMMAND),
    Claim("Turn signals: speaker consistency and |Pearson(heading change, bit)| rise with LiDAR noise",
          ("communication-paper-32M", "communication-paper-16M", "communication-paper"),
          (Reading(r"- speaker consistency \(bits\): noise "),
           Reading(r"- \|Pearson\(heading change, bit\)\|: noise "),
           # beside it: whether the bit says anything at each level, against bits that say nothing
           Reading(r"- speaker consistency \(bits\) against scripted drivers ", "learnt", decides=False)),
          "communication.speaker_consistency_bits", "speaker consistency", command=NUSCENES_COMMAND),
    # every leader counts (wrecks too: collided cars stay on the road in the paper's code as in
    # ours), the reading the verdict uses; leaders that move are the other reading, shown beside it
    Claim("98.45 % of following samples keep the speed-matching distance (the verdict counts every car ahead, "
          "wrecks included; moving leaders only is shown beside it)", ("right-of-way-paper-32M", "right-of-way"),
          (Reading(r"- safety_distance\.safe_share ", "lies inside our interval"),
           Reading(r"- safety_distance\.safe_share_moving_leader ", "lies inside our interval", decides=False),
           Reading(r"- safe-distance share against scripted drivers ")),
          "safety_distance.safe_share", "safe-distance share", command=NUSCENES_COMMAND),
    Claim("Cars leave the junction in the order they entered 85.25 +- 8.9 % of the time",
          ("right-of-way-paper-32M", "right-of-way"),
          (Reading(r"- right_of_way\.fifo_share ", "our mean is inside that spread"),
           Reading(r"- FIFO share against scripted drivers ")),
          "right_of_way.fifo_share", "FIFO share", command=NUSCENES_COMMAND),
)


def reading_verdict(line: str, reading: Reading) -> str:
    """One statement line read for its claim: :data:`REPRODUCED` (it agrees with the paper),
    :data:`NOT_DETECTED` (its interval straddles the comparison: "no ... detected", "neither
    shown"), :data:`DIFFERS` (a value of the paper's outside our interval or outside the paper's
    spread) or :data:`OPPOSITE` (an effect shown the other way)."""
    if reading.agrees in line:
        return REPRODUCED
    if "neither shown" in line or re.search(r"\bno [a-z ]+ detected\b", line):
        return NOT_DETECTED
    if "lies outside our interval" in line or "outside that spread" in line:
        return DIFFERS
    return OPPOSITE


def combined_verdict(verdicts: set[str]) -> str:
    """A claim's verdict from its parts' (:data:`PRECEDENCE`); no part read: not detected."""
    return next((v for v in PRECEDENCE if v in verdicts), REPRODUCED if verdicts else NOT_DETECTED)


def _plateau(result: SectionResult, metric: str, label: str) -> str:
    """Whether ``metric`` had stopped moving, over the section's grid points, in words; where it was
    too noisy to tell, how many seeds its spread would need to narrow the late change far enough."""
    if result.curves is None or metric not in result.curves[0]:
        return f"{label}: no learning curves"
    late = list(late_changes(result.curves, result.keys, metric).values())
    verdicts = [plateau_verdict(e) for e in late]
    counts = Counter(v or "one seed (no interval)" for v in verdicts)
    noisy = [seeds_to_settle(e) for e, v in zip(late, verdicts) if v == TOO_NOISY]
    settle = (f" (at the spread of its learning curves, {settle_words(noisy)} with curves would narrow its "
              f"late change to ±{PLATEAU_TOLERANCE:g})" if noisy else "")
    if len(counts) == 1:
        (verdict, n), = counts.items()
        return f"{label} {verdict} at {all_of(n, 'grid point', 'grid points')}{settle}"
    (first, n), *rest = counts.most_common()
    return (f"{label} {first} at {n} of {len(verdicts)} grid points, " + ", ".join(f"{v} at {k}" for v, k in rest)
            + settle)


def _deciding_lines(claim: Claim, result: SectionResult) -> list[tuple[str, Reading]]:
    """The section's statements on ``claim``, less those on one training seed (an estimate printed
    with :data:`~box2d_driving.metrics.stats.ONE_SEED`, no interval: a 32 M run with its first seed
    finished does not yet replace a smaller run with intervals)."""
    return [(line, r) for r in claim.readings for line in result.lines
            if re.match(r.pattern, line) and ONE_SEED not in line]


def _speaks_to_every_part(claim: Claim, result: SectionResult) -> bool:
    """Whether ``result`` has a statement for each of the claim's readings: a larger run that so
    far speaks to one part only (say the 8-car lanes, not yet the 4-car ones) does not yet replace a
    smaller run that speaks to all of them."""
    return {r for _, r in _deciding_lines(claim, result) if r.decides} == {r for r in claim.readings if r.decides}


def deciding_section(claim: Claim, found: dict[str, SectionResult]) -> Optional[str]:
    """The key of the section that decides ``claim`` among those found on the page: the first of
    its sections (largest budget first) with a statement for every part of the claim, else the
    first with any statement on it, else the first with trials; None where none has trials."""
    tried = [k for k in claim.sections if k in found]
    if not tried:
        return None
    return next((k for k in tried if _speaks_to_every_part(claim, found[k])),
                next((k for k in tried if _deciding_lines(claim, found[k])), tried[0]))


def claim_row(claim: Claim, found: dict[str, SectionResult]) -> list[str]:
    """The table's cells for ``claim``, from the sections found on the page (by key): the first of
    its sections (largest budget first) with a statement for every part of the claim (each of its
    readings), else the first with any statement on it, else the first with trials (a larger run
    whose trials are still too few for an interval). A claim none of whose sections has trials yet
    names the paper's run and the page section (:data:`SECTIONS`) that will test it."""
    key = deciding_section(claim, found)
    if key is None:
        try:
            planned = section(claim.sections[0])
            paper, where = planned.paper_budget, f"[{planned.title}](#{anchor(planned.title)}): "
        except KeyError:  # a claim whose section is not on the page
            paper, where = "", ""
        return [claim.words, paper, f"{where}not run yet", f"**{NOT_RUN}**", "no trials yet"]
    result = found[key]
    lines = _deciding_lines(claim, result)
    verdict = combined_verdict({reading_verdict(line, r) for line, r in lines if r.decides})
    seeds = sorted({len(g.seeds) for g in result.groups})
    if seeds == [1]:
        seeds_text = "1 seed"
    else:
        seeds_text = f"{seeds[0]} seeds" if len(seeds) == 1 else f"{seeds[0]}-{seeds[-1]} seeds"
    ours = f"[{result.title}](#{anchor(result.title)}): {_budget(result)}, {seeds_text}"
    if claim.command is not None:
        differs = deviations(section_settings(key), claim.command)
        ours += ("; unlike the paper's command: " + "; ".join(differs) if differs
                 else "; the paper's command but for the budget")
    now = f"**{verdict}**; {_plateau(result, claim.curve, claim.curve_label)}"
    said = "<br>".join(line[2:] for line, _ in lines) or "no statement yet (too few seeds for an interval)"
    return [claim.words, result.paper_budget, ours, now, said]


# a test's p-value as its statement prints it ("p = 0.014", "p = 0.164", or "p < 0.001":
# :func:`box2d_driving.metrics.stats.p_text`)
P_VALUE = re.compile(r"\bp ([=<]) (\d\.\d{3})\b")


def holm(p_values: list[float]) -> list[float]:
    """Holm's step-down adjustment of a family of p-values (same order): the k-th smallest of
    ``m`` is multiplied by ``m - k + 1``, capped at 1, and kept non-decreasing."""
    order = sorted(range(len(p_values)), key=lambda i: p_values[i])
    out, running = [0.0] * len(p_values), 0.0
    for rank, i in enumerate(order):
        running = max(running, min(1.0, (len(p_values) - rank) * p_values[i]))
        out[i] = running
    return out


def _adjusted_text(exact: float, bound: float) -> str:
    """A Holm-adjusted value for print: ``bound`` is the adjustment with every printed "p < 0.001"
    taken as 0.001, ``exact`` with those taken as 0; where they differ the true value lies
    between them, so the bound is printed as one ("< 0.004")."""
    if bound > exact:
        return f"< {bound:.3f}"
    return "< 0.001" if bound < 0.0005 else f"{bound:.3f}"


def with_holm(rows: list[list[str]]) -> list[list[str]]:
    """The claims rows with every printed p-value of their deciding statements followed by its
    Holm-adjusted value over the table's family (all the tests the table's verdicts rest on)."""
    found = [(r, m) for r, cells in enumerate(rows) for m in P_VALUE.finditer(cells[4])]
    if len(found) < 2:
        return rows
    bound = holm([float(m.group(2)) for _, m in found])
    exact = holm([float(m.group(2)) if m.group(1) == "=" else 0.0 for _, m in found])
    out = [list(cells) for cells in rows]
    by_row: dict[int, list[tuple[re.Match, str]]] = {}
    for (r, m), e, b in zip(found, exact, bound):
        by_row.setdefault(r, []).append((m, _adjusted_text(e, b)))
    for r, items in by_row.items():
        text = rows[r][4]
        for m, a in reversed(items):  # from the end, so earlier positions stay valid
            text = f"{text[:m.end()]} (Holm-adjusted over the table's {len(found)} tests: {a}){text[m.end():]}"
        out[r][4] = text
    return out


# the last column where the paper's own trainer has not run a claim
NOT_RUN_THERE = "not run there yet"


def claims_table(found: dict[str, SectionResult], arbiter: Optional[Mapping[str, str]] = None) -> list[str]:
    """The page's claims table (Markdown lines), a row per :data:`CLAIMS` entry, every p-value
    with its Holm-adjusted value beside it (:func:`with_holm`); the last column, the original
    trainer's cell ``arbiter[claim.arbiter]`` for the claims it has run, else :data:`NOT_RUN_THERE`."""
    cells = dict(arbiter or {})
    header = ["the paper's claim", "the paper's run", "our largest run so far", "now", "what decides it",
              "the paper's own code, in its world"]
    rows = with_holm([claim_row(c, found) for c in CLAIMS])
    return [row(header), separator(len(header)),
            *(row(ours + [cells.get(c.arbiter, NOT_RUN_THERE) if c.arbiter else NOT_RUN_THERE])
              for c, ours in zip(CLAIMS, rows))]


def worlds_sentence(found_sections: dict[str, SectionResult]) -> str:
    """Which of the claims table's rows are read from runs in the paper's own world and update
    (sections of the ``paper`` preset) and which from our default world, in words."""
    keys = [(c, key) for c in CLAIMS if (key := deciding_section(c, found_sections)) is not None
            and any(("preset", name) in section(key).match for name in ("paper", "paper-turns"))]
    preset = [c.words for c, _ in keys]
    turning = any(("preset", "paper-turns") in section(key).match for _, key in keys)
    # runs from before the preset drove on the left pin its mirror image (paper_world_sections.MIRROR_SETTINGS)
    mirrored = any(("drive_on", "right") in section(key).match for _, key in keys)
    world = ("the paper's own world and update (its arrived cars stay, its epochs are 32,000 joint steps, its "
             "entropy 1e-4: the `paper` preset, [paper_world.md](paper_world.md)"
             + ("; as the preset stood before 2026-12-06, the mirror image of that world, on the right, with an "
                "arrived car's heading error 0 and the distance to the goal read along the track: "
                "[what that changes](paper_world.md#policies-in-both-worlds)"
                if mirrored else "")
             + ("; the lone car on the junction of the paper's 1-car run, where cars turn and the entropy is "
                "1e-3: the `paper-turns` preset" if turning else "") + ")")
    if not preset:
        return f"None of these runs is yet in {world}; each row gives its share of the paper's joint steps."
    if len(preset) == len(CLAIMS):
        return f"Every one of these runs is in {world}; each row gives its share of the paper's joint steps."
    return (f"{len(preset)} of the {len(CLAIMS)} rows are read from runs in {world}: "
            + "; ".join(f"*{w}*" for w in preset)
            + "; the others from our default world (what differs: the same page); each row gives its share of the "
              "paper's joint steps.")


def claims_part(found_sections: dict[str, SectionResult], arbiter: dict[str, str]) -> list[str]:
    """The table of where the page stands on each of the paper's claims, with how to read it."""
    return ["## Where the page stands on the paper's claims", "",
            "Each of the paper's claims this page tests, read from its largest run so far that speaks to "
            "every part of the claim (a larger run with statements on only part of it so far is reported in its own "
            f"section below). {worlds_sentence(found_sections)} Each row also lists where its run differs from the "
            "paper's command beyond the budget (the world and its junctions, entropy, collision reward, where "
            "training started, the LiDAR encoder), read from the settings its sweep command builds. "
            "One rule decides every verdict: *reproduced* where the interval shows the effect in "
            "the paper's direction (excludes no effect), or holds the paper's value; *opposite* where it excludes no "
            "effect in the other direction; *not detected* where it straddles no effect (the statement says the "
            "largest effect in the paper's direction the interval still allows); *differs* where the paper gives a "
            "value and our interval excludes it. A claim of several parts takes the first of opposite, differs, not "
            "detected that any part has, else reproduced. Seed counts that would tell are planning estimates: they "
            "take the observed mean and spread as true. An interval reaching past its metric's range (a share below 0 "
            "or above 1, a correlation past +-1) is cut at the range and printed as [low, high]. Every p-value of "
            "the table stands with its Holm-adjusted value over the table's family of tests (the verdicts read the "
            "95 % intervals, which are not adjusted). And whether the claim's measure had stopped moving by the "
            "end of training "
            "(its learning curves on selection episodes; the section says how each was read) and, where that is too "
            "noisy to tell, how many seeds with curves the observed spread would need to settle it. The last column: "
            "what the paper's own trainer, run on the paper's own command in its own world, says (so far "
            + ("the noise claim and the lone car have" if "lone-car" in arbiter else "only the noise claim has")
            + " been run there).", "",
            *claims_table(found_sections, arbiter), ""]
