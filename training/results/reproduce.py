"""``box2d-driving reproduce``: the results page (docs/results.md) and its figures, redrawn from
sweep summaries alone (no checkpoints needed).

    box2d-driving reproduce                       # every summary in assets/sweeps -> docs/results.md
    box2d-driving reproduce SUMMARY.json [...] --out PAGE.md
    box2d-driving reproduce --run                 # first run or continue every rule's sweep
    box2d-driving reproduce --reevaluate --only traffic-lights-paper   # measure again from kept weights

One section per rule: the paper's result, ours as a mean over training seeds with a 95 % interval
and the per-seed values, a plain statement where ours falls outside the paper's interval, the
paper's figure redrawn from our data, and the command that reruns it. A rule whose sweep has not
been run yet says so. Only trials evaluated on report seeds are used; a summary with any other
episodes is refused.
"""

from __future__ import annotations

import dataclasses

import sys
from pathlib import Path
from typing import Any, Optional

from training.common.markdown import row, separator
from training.results.arbiter import (ORIGINAL_RUNS, arbiter_cell, arbiter_section, load_driver_reports,
                                      load_original_runs)
from training.results.lone_car_arbiter import lone_car_cell, lone_car_section
from training.results.original_runs import load_lone_car_runs
from training.results.claims import SectionResult, claims_part
from training.results.matching import grid_order, joined_groups, reference, section_summaries
from training.results.readme import README_START, readme_table, readme_text, update_readme
from training.results.curves import curve_figure, curves_path, load_curves, plateau_lines
from training.results.figures import COMPARED
from training.results.data import Group, ResultsError, grid_product, groups_of, load_summary
from training.results.lidar_blind import blind_line, start_line
from training.results.reevaluate import kept_count
from training.results.notes import (budget_note, carried_line, curve_coverage, joined_note, ran_budget,
                                    ran_decisions, trial_budget)
from training.results.sections import SECTIONS, PaperValue, Section, statements
from training.common.seeds import REPORT
from box2d_driving.metrics.stats import Estimate

__all__ = ["SECTIONS", "Group", "PaperValue", "ResultsError", "Section", "budget_note", "groups_of", "load_summary",
           "main", "ran_budget", "trial_budget", "write_gif", "write_page"]


from box2d_driving.single_agent import SHIPPED

LIGHTS = ("lights", "lanes", "real-junction")  # behaviours whose scenes have traffic lights
SUMMARIES = Path("assets/sweeps")  # the committed summaries, one per rule (SECTION.summary_name.json)


def write_gif(section: Section, path: Path, seed: int = REPORT.start) -> Path:
    """One report episode of the section's shipped policy as an animated GIF (needs the policy's
    checkpoint; the page itself does not)."""
    from box2d_driving.render.video import record
    from training.runs.inference import load_policy

    if section.shipped is None:
        raise ResultsError(f"{section.key}: no shipped policy to draw")
    policy = load_policy(SHIPPED / section.shipped)
    env = policy.make_env(render_mode="rgb_array", render_size=section.gif_size)
    record(env, policy, episodes=1, video=path, seed=seed, overwrite=True)
    env.close()
    return path


def _estimate_cell(e: Estimate, seeds: Optional[list[int]] = None, planned: Optional[int] = None) -> str:
    """An estimate with its per-seed values; with ``planned`` (the seeds run before any look at
    the results) each value of a seed added after an interim look is marked :data:`ADDED_MARK`."""
    if e.n == 0:
        return "n/a"
    if e.n == 1:
        return e.format()  # "x (1 seed)"
    marks = ([ADDED_MARK if planned is not None and s >= planned else "" for s in seeds]
             if seeds is not None and len(seeds) == len(e.values) else [""] * len(e.values))
    values = ", ".join(f"{v:.3f}{m}" for v, m in zip(e.values, marks))
    return f"{e.format()} ({values})"


def unplaced(summaries: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The summaries no section of the page shows."""
    shown = {id(s) for section in SECTIONS for s in section_summaries(section, summaries)}
    return [s for s in summaries if id(s) not in shown]


# marks a seed's value where the seed was added after an interim look at the results
ADDED_MARK = "†"  # not "*": Markdown would read pairs of them as emphasis


def write_page(summaries: list[dict[str, Any]], out: Path, figures: Path, gifs: bool = False,
               original: Path = ORIGINAL_RUNS) -> str:
    """Write the page to ``out`` (a table of where it stands on the paper's claims, then a section
    per rule, then the original trainer's runs carried in ``original``) and its figures into
    ``figures``; returns the page text. With ``gifs``, (re)draw each section's animation of its
    shipped policy first (needs the checkpoints; without, existing animations are linked)."""
    carried = Path(original).is_dir()
    runs, drivers, lone = ((load_original_runs(original), load_driver_reports(original), load_lone_car_runs(original))
                           if carried else ([], [], []))
    figures.mkdir(parents=True, exist_ok=True)
    rel = Path(_relative(figures, out.parent))
    parts = _page_intro()
    intro = len(parts)  # the claims table goes here, once the sections it reads are written
    found_sections: dict[str, SectionResult] = {}  # what each section found, for the claims table
    for section in SECTIONS:
        parts += _section_head(section, figures, rel, gifs)
        found = section_summaries(section, summaries)
        if not found:
            parts += [f"**Ours.** Not run yet. {section.setting} To run it: `box2d-driving reproduce --run --only "
                      f"{section.key}` runs this sweep, then adds it to this page:", "", "```bash", section.command,
                      "```", ""]
            continue
        for summary in found:
            lines, found_sections[section.key] = _summary_part(section, summary, summaries, figures, rel)
            parts += lines
        parts += [f"To rerun: `box2d-driving reproduce --run --only {section.key}` continues from the committed "
                  "summary (its finished trials are kept), then rewrites this page. It runs this sweep, which "
                  "also continues when run again with the same `--out`:", "",
                  "```bash", section.command, "```", ""]
    parts += arbiter_section(runs, figures, rel.as_posix(), drivers) + lone_car_section(lone, drivers)
    cells = {"noise": arbiter_cell(runs), **({"lone-car": lone_car_cell(lone, drivers)} if lone else {})}
    parts[intro:intro] = claims_part(found_sections, cells) + _glance_part(summaries)
    text = "\n".join(parts)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(out.name + ".partial")
    tmp.write_text(text)
    tmp.replace(out)
    return text


def _glance_part(summaries: list[dict[str, Any]]) -> list[str]:
    """Every rule's headline grid points in one table (the README shows the few marked for it)."""
    return ["## Every headline at a glance", "",
            "Each rule's headline grid points, as mean ± 95 % half-width over training seeds (an interval in "
            "brackets where it is cut at a share's range); the README's results table shows the largest run of "
            "each of the paper's claims from this table.", "",
            readme_table(summaries, page="", every_headline=True), ""]


def _page_intro() -> list[str]:
    """The page's title and what its numbers are."""
    from training.common.asset_budgets import ASSET_BUDGETS as budgets

    return ["# Results", "",
            "Generated by `box2d-driving reproduce` from the sweep summaries listed under each rule; "
            "do not edit by hand. Every number is measured on report episode seeds "
            f"({REPORT.describe()}), never seen in training or checkpoint selection, and given as the mean "
            "over training seeds with a 95 % t-interval (`mean ± half-width`), the per-seed values in "
            "brackets. How sweeps run: [sweeps.md](sweeps.md). `box2d-driving reproduce --run` runs every "
            "rule's sweep below in turn, continuing from the committed summaries, and rewrites this page. "
            "Each trial it lands keeps its final actor (`assets/sweeps/weights/NAME/TRIAL/`, about 0.3 MB a "
            "trial), and `box2d-driving reproduce --reevaluate [--only RULE]` measures those trials again on their own "
            "report episodes with today's metric code (a new measure, baseline or definition without retraining; "
            "each section says for how many of its trials); trials landed before 2026-12-04 kept none. "
            f"`assets/` stays within {budgets.mib(budgets.shipped)} besides those kept actors, which have "
            f"{budgets.mib(budgets.kept_weights)} of their own, and the paper's own trainer's runs "
            f"(`assets/original/`, {budgets.mib(budgets.original_runs)}: a run still training carries its optimiser "
            f"state to resume from), no file over {budgets.mib(budgets.file)} (`tests/test_shipped_policies.py`). "
            "In the paper's own world (the `paper` presets' sections) an arrived car stays until the horizon and can "
            "still crash, into the road's end or hit by another, so a car may count in both success and collisions, "
            "which then add to more than 1.", ""]


def _section_head(section: Section, figures: Path, rel: Path, gifs: bool) -> list[str]:
    """A section's title, the paper's claim, and the animation of its shipped policy where there is
    one (drawn first with ``gifs``)."""
    parts = [f"## {section.title}", "", f"**Paper.** {section.paper}", ""]
    gif = figures / f"{section.key}.gif"
    if gifs and section.shipped is not None:
        write_gif(section, gif)
    if gif.exists():
        parts += [f"![{section.title}: the shipped policy]({(rel / gif.name).as_posix()})", "",
                  f"*The shipped policy `assets/policies/{section.shipped}`, one report episode "
                  f"(seed {REPORT.start:,})"
                  + ("; lights drawn in the convention it adopted" if section.behaviour in LIGHTS else "")
                  + ".*", ""]
    return parts


def _summary_part(section: Section, summary: dict[str, Any], summaries: list[dict[str, Any]], figures: Path,
                  rel: Path) -> tuple[list[str], SectionResult]:
    """What one of a section's summaries found: its budget, the table over grid points, the
    statements, the figure, the learning curves and the trials not finished; and what the claims
    table reads from it."""
    metrics = [m for m, _ in section.metrics]
    keys = list(summary["grid"])
    joined, joined_paths = joined_groups(section, summaries, summary, metrics)
    own = groups_of(summary, metrics)
    groups = grid_order(own + joined, keys) if joined else own
    trials = summary["trials"]
    done = sum(r.get("status") == "done" for r in trials)
    # seeds the command now asks for count as planned before a run adds them to the summary
    seeds = summary["sweep"]["seeds"]
    own_sweep = Path(summary["path"]).stem == section.summary_name  # the one `--only KEY` runs
    if own_sweep:
        seeds = max(seeds, section.seeds)
    planned = len(grid_product([summary["grid"][k] for k in keys])) * seeds
    # finished trials only: a trial carried part-way has curve rows before it has a summary row
    curves = load_curves(curves_path(summary["path"]), keys,
                         trials={r["trial"] for r in trials if r.get("status") == "done"})
    kept, _ = kept_count(Path(summary["path"]), trials)
    weights = (f"; final weights kept for {kept} of the {done}, which `reproduce --reevaluate` can measure again"
               if done else "")
    parts = [f"**Ours** ({done} of {planned} planned trials done; summary `{summary['path']}`; "
             f"{trial_budget(summary['sweep'])} per trial{ran_budget(trials)}, "
             f"{summary['sweep']['episodes']} report episodes each{weights}). {section.setting}"
             + budget_note(section, curves is not None) + joined_note(section, joined_paths, joined), ""]
    if groups:
        header = [*keys, "seeds", *(label for _, label in section.metrics)]
        parts += [row(header), separator(len(header))]
        for g in groups:
            cells = [g.point[k] for k in keys] + [str(len(g.seeds))]
            cells += [_estimate_cell(g.estimates[m], g.seeds, section.seeds_before_look) for m in metrics]
            parts.append(row(cells))
        parts.append("")
    else:  # trials stopped part-way or pending only: no row to show yet, and no empty table
        parts += ["No trial has finished yet: the table comes with the first.", ""]
    blind = blind_line(summary, keys)
    carried = carried_line(summary, f"box2d-driving reproduce --run --only {section.key}" if own_sweep else None)
    for line in (carried, start_line(summary, kept), blind):
        if line:
            parts += [line, ""]
    if section.seeds_before_look is not None and any(s >= section.seeds_before_look for g in groups for s in g.seeds):
        parts += [f"Values marked {ADDED_MARK} are of seeds added after an interim look at the results (seeds "
                  f"0-{section.seeds_before_look - 1} were planned first; the setting above says why more were "
                  "added); the intervals are not corrected for that look.", ""]
    # scripted drivers are scored on the finished trials' report episodes: none finished, none to score
    baseline = section.baseline(summary, groups) if section.baseline is not None and done else {}
    notes = statements(section, groups, baseline, *reference(section, summaries))
    result = SectionResult(section.title, section.paper_budget, trial_budget(summary["sweep"]), groups, notes,
                           curves, keys, tuple(ran_decisions(trials)), section.paper_joint_steps, section.cars)
    if notes:
        parts += notes + [""]
    if section.figure is not None and groups:
        name = f"{section.key}.png"
        compared, words = reference(section, summaries)
        shown = groups if compared is None else groups + [  # the row the statements compare with, its own bar
            dataclasses.replace(compared, point={COMPARED: words.removeprefix("the row ").replace(" of ", "\nof ", 1)})]
        section.figure(shown, keys, figures / name, baseline)
        parts += [f"![{section.title}]({(rel / name).as_posix()})", ""]
    if curves is not None:
        followed = [(m, label) for m, label in section.metrics if isinstance(m, str)] + list(section.curve_extra)
        name = f"{section.key}_curves.png"
        curve_figure(curves, keys, followed, figures / name)
        parts += [f"**Learning curves** (`{curves_path(summary['path'])}`; selection seeds from "
                  f"{int(curves[0]['first_seed']):,}{curve_coverage(curves, trials, keys)}):", ""]
        parts += plateau_lines(curves, keys, followed) + [""]
        parts += [f"![{section.title}: learning curves]({(rel / name).as_posix()})", ""]
    failed = [r for r in trials if r.get("status") in ("error", "stopped")]
    if failed:
        parts += ["Trials not finished (`box2d-driving reproduce --run` runs them again, from their last "
                  "checkpoint where their run folder under `runs/` is still there, else from the start): "
                  + ", ".join(f"`{r['trial']}` ({r['status']})" for r in failed), ""]
    return parts, result


def _relative(target: Path, start: Path) -> str:
    import os

    return os.path.relpath(Path(target).resolve(), Path(start).resolve())


def default_summaries(folder: Path) -> list[Path]:
    """The summaries in ``folder`` (``*.json``; the page places each under its rule);
    :class:`ResultsError` when there are none (a page written from nothing would replace the
    committed one with empty tables)."""
    folder = Path(folder)
    if not folder.is_dir():
        raise ResultsError(f"--summaries {folder}: no such folder")
    found = sorted(folder.glob("*.json"))
    if not found:
        raise ResultsError(f"--summaries {folder}: no sweep summaries (*.json) in it")
    return found


def main(argv: Optional[list[str]] = None) -> int:
    """``box2d-driving reproduce``: with ``--run`` first run (or continue) the sections' sweeps; then
    write the page and its figures (and, with ``--readme``, the README's results); returns the exit
    status."""
    from training.common.cli_args import OneLineParser

    p = OneLineParser(prog="box2d-driving reproduce",
                      description="Write the results page and its figures from sweep summaries (summary.json); "
                                  "with --run, first run (or continue) every rule's sweep on Ray Tune.")
    p.add_argument("summaries", nargs="*", type=Path,
                   help="summary.json files of sweeps (default: every *.json in --summaries)")
    p.add_argument("--summaries", dest="folder", type=Path, default=SUMMARIES,
                   help="folder of the per-rule summaries (default assets/sweeps); --run continues them "
                        "and writes them back there")
    p.add_argument("--out", type=Path, default=Path("docs/results.md"), help="the page (default docs/results.md)")
    p.add_argument("--figures", type=Path, help="folder for the figures (default: images/results beside the page)")
    p.add_argument("--gifs", action="store_true",
                   help="also redraw each rule's animated GIF of its shipped policy (needs the train extra "
                        "and assets/policies; without it, existing GIFs are linked)")
    p.add_argument("--readme", type=Path, metavar="README",
                   help="also rewrite the results table between the README's markers (" + README_START + ")")
    run = p.add_argument_group("--run: the paper's grid in one command")
    run.add_argument("--run", action="store_true",
                     help="run every rule's sweep in turn (the commands on the page), continuing each from "
                          "its summary in --summaries; stop it any time and run it again to go on")
    run.add_argument("--only", nargs="+", metavar="RULE", choices=[s.key for s in SECTIONS],
                     help="with --run or --reevaluate, these rules only: " + ", ".join(s.key for s in SECTIONS))
    run.add_argument("--runs", type=Path, default=Path("runs"), help="where the sweep folders go (default runs)")
    run.add_argument("--cpus-per-trial", type=float,
                     help="CPU cores per trial, for every rule (default: each rule's command's; its trials' "
                          "torch threads follow, and trials retrace only under the same number)")
    run.add_argument("--gpus-per-trial", type=float, default=0, help="GPUs per trial (default 0)")
    run.add_argument("--max-concurrent", type=int,
                     help="at most this many trials at once, for every rule (default: each rule's command's)")
    run.add_argument("--address", help="a running Ray cluster (default: this machine)")
    run.add_argument("--time-limit", type=float, metavar="MINUTES",
                     help="stop after this many minutes of wall-clock time, as Ctrl-C would (trials part-way are "
                          "carried beside the summaries; leave time for their curves to be drawn): for a "
                          "machine lent for a fixed time")
    p.add_argument("--reevaluate", action="store_true",
                   help="first measure every finished trial again from the final weights it kept "
                        "(SUMMARIES/weights/NAME/TRIAL), on the report episodes its row was measured on, with "
                        "today's metric code; rewrite its summary's report columns, then the page (trials that "
                        "kept no weights keep their rows and are listed)")
    args = p.parse_args(argv)
    prog = "box2d-driving reproduce"
    if args.only and not (args.run or args.reevaluate):
        p.error("--only goes with --run or --reevaluate")
    if args.run and args.reevaluate:
        p.error("--run evaluates the trials it trains; --reevaluate is for trials already landed: choose one")
    if args.reevaluate and args.summaries:
        p.error("--reevaluate rewrites the summaries in --summaries; give no summary files")
    if args.run and args.summaries:
        p.error("--run reads and writes the summaries in --summaries; give no summary files")
    if args.time_limit is not None and not args.run:
        p.error("--time-limit goes with --run")
    figures = args.figures or args.out.parent / "images" / "results"
    status = 0
    if args.run:
        from training.results.run_all import ReproduceError, run_sections
        from training.sweeps.deadline import Deadline
        from training.sweeps.spec import SweepError

        try:
            deadline = Deadline.after_minutes(args.time_limit)  # counted from the start of the command
        except SweepError as exc:
            print(f"{prog}: error: {exc}", file=sys.stderr)
            return 2
        if args.readme is not None:  # a README it cannot write is found before hours of training
            try:
                readme_text(args.readme)
            except ResultsError as exc:
                print(f"{prog}: error: {exc}", file=sys.stderr)
                return 2

        try:
            status = run_sections([s for s in SECTIONS if not args.only or s.key in args.only], args.folder,
                                  args.runs, args.cpus_per_trial, args.gpus_per_trial, args.max_concurrent,
                                  args.address, deadline)
        except ReproduceError as exc:
            print(f"{prog}: error: {exc}", file=sys.stderr)
            return 2
    if args.reevaluate:
        from training.results.reevaluate import reevaluate_summary

        chosen = [s for s in SECTIONS if not args.only or s.key in args.only]
        names = list(dict.fromkeys(s.summary_name for s in chosen))
        try:
            for name in names:
                path = Path(args.folder) / f"{name}.json"
                if not path.exists():
                    if args.only:
                        raise ResultsError(f"--only: no summary {path} to re-evaluate")
                    continue
                for line in reevaluate_summary(path).lines():
                    print(line)
        except ResultsError as exc:
            print(f"{prog}: error: {exc}", file=sys.stderr)
            return 2
    try:
        paths = args.summaries or default_summaries(args.folder)
        summaries = [load_summary(s) for s in paths]
        if args.readme is not None:  # checked first: a bad README leaves the page as it was
            update_readme(args.readme, readme_table(summaries, _relative(args.out, args.readme.parent)))
        write_page(summaries, args.out, figures, gifs=args.gifs)
    except ResultsError as exc:
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return 2
    for summary in unplaced(summaries):
        print(f"{prog}: warning: {summary['path']} measures no rule of the page (its behaviour and fixed options "
              f"match no section's, e.g. a preset's sweep at other settings than the page's): left out",
              file=sys.stderr)
    print(f"wrote {args.out} and its figures in {figures}")
    return status


if __name__ == "__main__":
    raise SystemExit(main())
