"""``box2d-driving reproduce``: the results page (docs/results.md) and its figures, redrawn from
sweep summaries alone (no checkpoints needed).

    box2d-driving reproduce                       # every summary in assets/sweeps -> docs/results.md
    box2d-driving reproduce SUMMARY.json [...] --out PAGE.md
    box2d-driving reproduce --run                 # first run or continue every rule's sweep

One section per rule: the paper's result, ours as a mean over training seeds with a 95 % interval
and the per-seed values, a plain statement where ours falls outside the paper's interval, the
paper's figure redrawn from our data, and the command that reruns it. A rule whose sweep has not
been run yet says so. Only trials evaluated on report seeds are used; a summary with any other
episodes is refused.
"""

from __future__ import annotations

import math
import sys
from collections import defaultdict
from pathlib import Path
from typing import Any, Optional

from training.results_data import (LEARNT_SUCCESS, Group, ResultsError, as_number, grid_product, groups_of, light_blind_violation_rate,
                                   load_summary, report_episodes)
from training.results_sections import SECTIONS, PaperValue, Section
from training.seeds import REPORT
from training.stats import Estimate

__all__ = ["SECTIONS", "Group", "PaperValue", "ResultsError", "Section", "groups_of", "load_summary", "main", "write_gif",
           "write_page"]


from box2d_driving.envs.single_agent import SHIPPED  # noqa: E402  (assets/policies)

LIGHTS = ("lights", "lanes", "real-junction")  # behaviours whose scenes have traffic lights
SUMMARIES = Path("assets/sweeps")  # the committed summaries, one per rule (SECTION.summary_name.json)


def write_gif(section: Section, path: Path, seed: int = REPORT.start) -> Path:
    """One report episode of the section's shipped policy as an animated GIF (needs the policy's
    checkpoint; the page itself does not)."""
    from box2d_driving.render.video import record
    from training.inference import load_policy

    policy = load_policy(SHIPPED / section.shipped)
    env = policy.make_env(render_mode="rgb_array", render_size=section.gif_size)
    record(env, policy, episodes=1, video=path, seed=seed, overwrite=True)
    env.close()
    return path


def section_summaries(section: Section, summaries: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The summaries that measure ``section``: its behaviour, its fixed options."""
    out = []
    for s in summaries:
        sweep = s["sweep"]
        if sweep["behaviour"] != section.behaviour:
            continue
        settings = {**sweep.get("fixed", {}), **{k: None for k in s["grid"]}}
        if all(str(settings.get(k, "false")).lower() == v for k, v in section.match):
            out.append(s)
    return out


def _estimate_cell(e: Estimate) -> str:
    if e.n == 0:
        return "n/a"
    if e.n == 1:
        return e.format()  # "x (1 seed)"
    seeds = ", ".join(f"{v:.3f}" for v in e.values)
    return f"{e.format()} ({seeds})"


def _comparison(section: Section, groups: list[Group]) -> list[str]:
    lines = []
    for pv in section.paper_values:
        for g in groups:
            e = g.estimates.get(pv.metric)
            if e is None or e.n == 0:
                continue
            where = ", ".join(f"{k}={v}" for k, v in g.point.items()) or "shipped settings"
            if pv.spread is not None:
                inside = abs(e.mean - pv.value) <= pv.spread
                verdict = "inside" if inside else "outside"
                lines.append(f"- {pv.metric} ({where}): ours {e.format()} against the paper's {pv.text}: "
                             f"our mean is {verdict} the paper's interval.")
            else:
                held = e.contains(pv.value)
                verdict = ("the paper's value lies inside our interval" if held else
                           "the paper's value lies outside our interval" if held is False else
                           "one seed only: no interval")
                lines.append(f"- {pv.metric} ({where}): ours {e.format()} against the paper's {pv.text}: "
                             f"{verdict}.")
    return lines


def lights_statement(groups: list[Group], blind: dict[str, tuple[float, int]]) -> list[str]:
    """Plain statements of the lights trends, from the intervals. ``blind``: per noise level, the
    light-blind driver's violation rate on the same report episodes and its number of entries."""
    lines = []
    by_noise: dict[str, dict[float, Estimate]] = defaultdict(dict)
    for g in groups:
        by_noise[g.point.get("lidar_noise", "?")][as_number(g.point.get("num_cars"))] = g.estimates["red_light_violation_rate"]
    for noise in sorted(by_noise, key=as_number):
        cars = by_noise[noise]
        if 1.0 in cars and noise in blind and cars[1.0].n:
            one, (rate, entries) = cars[1.0], blind[noise]
            # the blind rate is itself measured on `entries` junction entries: its 95 % binomial margin
            margin = 1.96 * math.sqrt(max(rate * (1 - rate), 1e-12) / max(entries, 1))
            ignored = abs(one.mean - rate) <= margin
            lines.append(f"- noise {noise}, 1 car: violations {one.format()}, a light-blind driver (full throttle) on "
                         f"the same episodes {rate:.3f} ± {margin:.3f}: "
                         + ("no different: the light is ignored, as in the paper." if ignored else
                            "different: the lone car reacts to the light, unlike the paper."))
        for n in sorted(c for c in cars if c > 1.0):
            one, many = cars.get(1.0), cars[n]
            if one is not None and one.high is not None and many.high is not None:
                apart = many.high < one.low
                lines.append(f"- noise {noise}: 1 car {one.format()}, {n:g} cars {many.format()}: "
                             + ("fewer violations with more cars, intervals apart." if apart else
                                "the intervals overlap: no difference shown."))
    return lines


def noise_trend_statement(groups: list[Group], metrics: list[tuple[str, str]]) -> list[str]:
    """Whether each metric rises from the lowest to the highest LiDAR noise, from the intervals."""
    by_noise = sorted((g for g in groups if "lidar_noise" in g.point), key=lambda g: as_number(g.point["lidar_noise"]))
    if len(by_noise) < 2:
        return []
    low, high = by_noise[0], by_noise[-1]
    lines = []
    for metric, label in metrics:
        a, b = low.estimates[metric], high.estimates[metric]
        if a.high is None or b.high is None:
            continue
        verdict = ("rises, intervals apart, as in the paper." if b.low > a.high else
                   "falls, intervals apart, unlike the paper." if b.high < a.low else
                   "the intervals overlap: no rise shown, unlike the paper.")
        lines.append(f"- {label}: noise {low.point['lidar_noise']} {a.format()}, noise "
                     f"{high.point['lidar_noise']} {b.format()}: {verdict}")
    return lines


def light_blind_rates(summary: dict[str, Any], groups: list[Group]) -> dict[str, tuple[float, int]]:
    """Per noise level with a 1-car grid point: the light-blind driver's violation rate on the
    trials' report episodes, and its number of junction entries (1 car: one per episode)."""
    first, episodes = report_episodes(summary)
    return {g.point["lidar_noise"]: (light_blind_violation_rate(1, as_number(g.point["lidar_noise"]), first, episodes),
                                     episodes)
            for g in groups if as_number(g.point.get("num_cars")) == 1.0 and "lidar_noise" in g.point}


def unlearnt_statement(groups: list[Group]) -> list[str]:
    """Grid points whose cars mostly fail to arrive: their rule measures say little."""
    lines = []
    for g in groups:
        e = g.estimates.get("success_rate")
        if e is not None and e.n and e.mean < LEARNT_SUCCESS:
            where = ", ".join(f"{k}={v}" for k, v in g.point.items()) or "shipped settings"
            lines.append(f"- {where}: success {e.format()}: at this budget the cars have not learnt to reach "
                         "their goals, so the other numbers of this row say little about the rule.")
    return lines


def write_page(summaries: list[dict[str, Any]], out: Path, figures: Path, gifs: bool = False) -> str:
    """Write the page to ``out`` and its figures into ``figures``; returns the page text. With
    ``gifs``, (re)draw each section's animation of its shipped policy first (needs the checkpoints;
    without, existing animations are linked)."""
    figures.mkdir(parents=True, exist_ok=True)
    rel = Path(_relative(figures, out.parent))
    parts = ["# Results", "",
             "Generated by `box2d-driving reproduce` from the sweep summaries listed under each rule; "
             "do not edit by hand. Every number is measured on report episode seeds "
             f"({REPORT.describe()}), never seen in training or checkpoint selection, and given as the mean "
             "over training seeds with a 95 % t-interval (`mean ± half-width`), the per-seed values in "
             "brackets. How sweeps run: [sweeps.md](sweeps.md). `box2d-driving reproduce --run` runs every "
             "rule's sweep below in turn, continuing from the committed summaries, and rewrites this page.", ""]
    for section in SECTIONS:
        parts += [f"## {section.title}", "", f"**Paper.** {section.paper}", ""]
        gif = figures / f"{section.key}.gif"
        if gifs and section.shipped is not None:
            write_gif(section, gif)
        if gif.exists():
            parts += [f"![{section.title}: the shipped policy]({(rel / gif.name).as_posix()})", "",
                      f"*The shipped policy `assets/policies/{section.shipped}`, one report episode "
                      f"(seed {REPORT.start:,})"
                      + ("; lights drawn in the convention it adopted" if section.behaviour in LIGHTS else "")
                      + ".*", ""]
        found = section_summaries(section, summaries)
        if not found:
            parts += [f"**Ours.** Not run yet. {section.setting} To run it:", "", "```bash", section.command,
                      "```", ""]
            continue
        for summary in found:
            metrics = [m for m, _ in section.metrics]
            groups = groups_of(summary, metrics)
            keys = list(summary["grid"])
            trials = summary["trials"]
            done = sum(r.get("status") == "done" for r in trials)
            planned = len(grid_product([summary["grid"][k] for k in keys])) * summary["sweep"]["seeds"]
            parts += [f"**Ours** ({done} of {planned} planned trials done; summary `{summary['path']}`; "
                      + (f"{summary['sweep']['timesteps']:,}" if summary['sweep'].get('timesteps') else "the default")
                      + " decisions per trial"
                      + (f", {summary['sweep']['minutes']} min" if summary['sweep'].get('minutes') else "")
                      + f", {summary['sweep']['episodes']} report episodes each). {section.setting}", ""]
            header = [*keys, "seeds", *(label for _, label in section.metrics)]
            parts += ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
            for g in groups:
                cells = [g.point[k] for k in keys] + [str(len(g.seeds))]
                cells += [_estimate_cell(g.estimates[m]) for m in metrics]
                parts.append("| " + " | ".join(cells) + " |")
            parts.append("")
            notes = _comparison(section, groups)
            blind = light_blind_rates(summary, groups) if section.key == "traffic-lights" else {}
            if section.key == "traffic-lights":
                notes += lights_statement(groups, blind)
            if section.key == "communication":
                notes += noise_trend_statement(groups, list(section.metrics[:2]))
            notes += unlearnt_statement(groups)
            if notes:
                parts += notes + [""]
            if section.figure is not None and groups:
                name = f"{section.key}.png"
                if blind:
                    section.figure(groups, keys, figures / name, blind=blind)
                else:
                    section.figure(groups, keys, figures / name)
                parts += [f"![{section.title}]({(rel / name).as_posix()})", ""]
            failed = [r for r in trials if r.get("status") in ("error", "stopped")]
            if failed:
                parts += ["Trials not finished (a rerun continues them): "
                          + ", ".join(f"`{r['trial']}` ({r['status']})" for r in failed), ""]
        parts += ["To rerun (a stopped sweep continues when the command is run again; on another "
                  "machine, add `--reuse` with the committed summary to keep its finished trials):", "",
                  "```bash", section.command, "```", ""]
    text = "\n".join(parts)
    out.parent.mkdir(parents=True, exist_ok=True)
    tmp = out.with_name(out.name + ".partial")
    tmp.write_text(text)
    tmp.replace(out)
    return text


README_START = "<!-- results over training seeds: written by box2d-driving reproduce --readme -->"
README_END = "<!-- end of results over training seeds -->"


def anchor(title: str) -> str:
    """The heading's link anchor as GitHub makes it (lower case, punctuation dropped, spaces to -)."""
    return "".join(c for c in title.lower() if c.isalnum() or c in " -_").replace(" ", "-")


def readme_table(summaries: list[dict[str, Any]], page: str = "docs/results.md") -> str:
    """The README's results table: each rule's headline grid points as mean ± 95 % half-width over
    training seeds, with the number of seeds and a link to the rule's section of ``page``."""
    lines = ["| rule | setting | ours on report episodes: mean ± 95 % half-width over training seeds | seeds | details |",
             "|---|---|---|---|---|"]
    for section in SECTIONS:
        labels = dict(section.metrics)
        found = section_summaries(section, summaries)
        for h in section.headlines:
            want = dict(h.point)
            groups = [g for s in found for g in groups_of(s, list(h.metrics))
                      if all(str(g.point.get(k)) == v for k, v in want.items())]
            if groups:
                g = max(groups, key=lambda g: len(g.seeds))
                result = "; ".join(f"{labels.get(m, m)} {_headline_value(g.estimates[m])}" for m in h.metrics)
                seeds = str(len(g.seeds))
            else:
                result, seeds = "not run yet", "0"
            lines.append(f"| {h.rule} | {h.setting} | {result} | {seeds} | "
                         f"[{section.title}]({page}#{anchor(section.title)}) |")
    return "\n".join(lines)


def _headline_value(e: Estimate) -> str:
    if e.n == 0:
        return "n/a"
    return e.format() if e.low is not None else f"{e.mean:.3f}"  # the seeds column says "1"


def update_readme(path: Path, table: str) -> None:
    """Replace the text between the README's two result markers with ``table``."""
    try:
        text = Path(path).read_text()
    except OSError as exc:
        raise ResultsError(f"--readme {path}: {exc.strerror}") from None
    if text.count(README_START) != 1 or text.count(README_END) != 1 or text.index(README_START) > text.index(README_END):
        raise ResultsError(f"--readme {path}: needs one line {README_START!r} and, after it, one line {README_END!r}")
    head, rest = text.split(README_START)
    tail = rest.split(README_END)[1]
    tmp = Path(path).with_name(Path(path).name + ".partial")
    tmp.write_text(f"{head}{README_START}\n{table}\n{README_END}{tail}")
    tmp.replace(path)


def _relative(target: Path, start: Path) -> str:
    import os

    return os.path.relpath(Path(target).resolve(), Path(start).resolve())


def default_summaries(folder: Path) -> list[Path]:
    """The summaries in ``folder`` (``*.json``; the page places each under its rule)."""
    return sorted(Path(folder).glob("*.json"))


def main(argv: Optional[list[str]] = None) -> int:
    from training.cli_args import OneLineParser

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
                     help="these rules only: " + ", ".join(s.key for s in SECTIONS))
    run.add_argument("--runs", type=Path, default=Path("runs"), help="where the sweep folders go (default runs)")
    run.add_argument("--cpus-per-trial", type=float, default=1, help="CPU cores per trial (default 1)")
    run.add_argument("--gpus-per-trial", type=float, default=0, help="GPUs per trial (default 0)")
    run.add_argument("--max-concurrent", type=int, help="at most this many trials at once")
    run.add_argument("--address", help="a running Ray cluster (default: this machine)")
    args = p.parse_args(argv)
    prog = "box2d-driving reproduce"
    if args.only and not args.run:
        p.error("--only goes with --run")
    if args.run and args.summaries:
        p.error("--run reads and writes the summaries in --summaries; give no summary files")
    figures = args.figures or args.out.parent / "images" / "results"
    status = 0
    if args.run:
        from training.reproduce_run import ReproduceError, run_sections

        try:
            status = run_sections([s for s in SECTIONS if not args.only or s.key in args.only], args.folder,
                                  args.runs, args.cpus_per_trial, args.gpus_per_trial, args.max_concurrent,
                                  args.address)
        except ReproduceError as exc:
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
    print(f"wrote {args.out} and its figures in {figures}")
    return status


if __name__ == "__main__":
    raise SystemExit(main())
