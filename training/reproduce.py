"""``box2d-driving reproduce``: the results page (docs/results.md) and its figures, redrawn from
sweep summaries alone (no checkpoints needed).

    box2d-driving reproduce assets/sweeps/lights.json [more summaries ...] --out docs/results.md

One section per rule: the paper's result, ours as a mean over training seeds with a 95 % interval
and the per-seed values, a plain statement where ours falls outside the paper's interval, the
paper's figure redrawn from our data, and the command that reruns it. A rule whose sweep has not
been run yet says so. Only trials evaluated on report seeds are used; a summary with any other
episodes is refused.
"""

from __future__ import annotations

import sys
from collections import defaultdict
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Optional

from training import figure_data as fd
from training.results_data import Group, ResultsError, as_number, grid_product, groups_of, load_summary
from training.results_figures import bars_figure, distribution_figure, gap_figure, lights_figure
from training.seeds import REPORT
from training.stats import Estimate

__all__ = ["SECTIONS", "Group", "ResultsError", "Section", "groups_of", "load_summary", "main", "write_gif",
           "write_page"]


@dataclass(frozen=True)
class PaperValue:
    """A number the paper reports for a metric: value and, where given, its +- spread."""

    metric: str
    value: float
    spread: Optional[float] = None
    text: str = ""


@dataclass(frozen=True)
class Section:
    """One rule on the page.

    Attributes:
        key: anchor and figure file stem.
        title: heading.
        behaviour: the sweep behaviour that measures it.
        match: fixed training options a sweep must have for this section (e.g. communication on).
        metrics: (metric column, label) shown in the table.
        paper: the paper's result in words.
        paper_values: the paper's numbers to compare ours with.
        command: the sweep that produces it.
        figure: draws the section's figure from the grouped estimates (None: table only).
    """

    key: str
    title: str
    behaviour: str
    match: tuple[tuple[str, str], ...]
    metrics: tuple[tuple[str, str], ...]
    paper: str
    command: str
    paper_values: tuple[PaperValue, ...] = ()
    figure: Optional[Callable[[list["Group"], list[str], Path], None]] = None
    shipped: Optional[str] = None  # the shipped policy animated in the section (assets/policies/...)
    gif_size: tuple[int, int] = (320, 320)


# -- the page ---------------------------------------------------------------------------------
SWEEP = "box2d-driving sweep"
SECTIONS: tuple[Section, ...] = (
    Section("traffic-lights", "Stopping at red lights", "lights", (),
            (("red_light_violation_rate", "red-light violations"), ("success_rate", "success"),
             ("collision_rate", "collisions")),
            "With one car the light is ignored; with more cars and more LiDAR noise, fewer cars enter "
            "on red (the paper shows this as histograms, without numbers).",
            f"{SWEEP} lights --grid lidar_noise=0,0.25,0.5,0.75 num_cars=1,4,8 --seeds 3 --timesteps 991552 "
            "--out runs/sweep-lights", figure=lights_figure, shipped="traffic_lights_4cars_noise05"),
    Section("lanes", "Lanes", "lanes", (),
            (("lanes.majority_share", "crossings on the majority side"), ("lanes.time_share_majority",
             "time on the majority side"), ("success_rate", "success")),
            "With 8 cars and noisy LiDAR, cars settle on one side of the road; with 2 cars they do not.",
            f"{SWEEP} lanes --grid num_cars=2,8 --seeds 3 --set lidar_noise=0.5 rounds=40 "
            "init_from=assets/policies/traffic_lights_4cars_noise05 --out runs/sweep-lanes",
            figure=distribution_figure("lane_position_counts", fd.LANE_BINS,
                                       "lane position inside the junction (+ = right of the axis)",
                                       bars_figure("lanes.majority_share", "share on the majority side")),
            shipped="lanes_8cars_noise05"),
    Section("right-of-way", "Right of way and safe distance", "real-junction", (("communication", "false"),),
            (("right_of_way.fifo_share", "FIFO share"), ("safety_distance.safe_share", "safe-distance share"),
             ("success_rate", "success"), ("collision_rate", "collisions")),
            "Cars leave the junction in the order they entered 85.25 +- 8.9 % of the time; 98.45 % of "
            "following samples keep the speed-matching distance (human drivers in nuScenes: 99.56 %).",
            f"{SWEEP} real-junction --seeds 3 --minutes 75 --set num_cars=8 "
            "init_from=assets/policies/traffic_lights_4cars --out runs/sweep-real-junction",
            paper_values=(PaperValue("right_of_way.fifo_share", 0.8525, 0.089, "85.25 +- 8.9 %"),
                          PaperValue("safety_distance.safe_share", 0.9845, None, "98.45 %")),
            figure=gap_figure(bars_figure("right_of_way.fifo_share", "FIFO share")),
            shipped="real_junction_8cars_collision3"),
    Section("communication", "Turn signals (communication)", "real-junction", (("communication", "true"),),
            (("communication.speaker_consistency_bits", "speaker consistency (bits)"),
             ("communication.pearson_heading_change_bit", "Pearson(heading change, bit)"),
             ("success_rate", "success")),
            "Speaker consistency and |Pearson(heading change, bit)| both rise with LiDAR noise.",
            f"{SWEEP} real-junction --grid lidar_noise=0,0.25,0.5,0.75 --seeds 3 --minutes 40 "
            "--set communication=true num_cars=8 --out runs/sweep-communication",
            figure=bars_figure("communication.speaker_consistency_bits", "speaker consistency (bits)"),
            shipped="real_junction_comm_8cars/noise05"),
    Section("fast-lanes", "Fast lanes", "fast-lanes", (),
            (("fast_lanes.pearson_r", "Pearson(rating, lateral)"), ("success_rate", "success")),
            "Faster cars keep to one side of the highway.",
            f"{SWEEP} fast-lanes --seeds 3 --set num_cars=10 rounds=40 --out runs/sweep-fast-lanes",
            figure=bars_figure("fast_lanes.pearson_r", "Pearson(rating, lateral position)"),
            shipped="fast_lanes_10cars", gif_size=(640, 200)),
    Section("pedestrians", "Slowing down for pedestrians", "crosswalk", (),
            (("pedestrian_collision_rate", "pedestrian collisions"), ("safe_stopping_share", "safe-stopping share"),
             ("share_more_than_6m", "samples > 6 m from the pedestrian"), ("success_rate", "success")),
            "Most cars keep more than the speed-matching distance from pedestrians (more than 6 m).",
            f"{SWEEP} crosswalk --seeds 3 --minutes 120 --set crosswalk_in_satnav=true --out runs/sweep-crosswalk",
            figure=distribution_figure("pedestrian_distance_counts", fd.PEDESTRIAN_BINS,
                                       "distance to the nearest pedestrian ahead (m)",
                                       bars_figure("safe_stopping_share", "safe-stopping share"),
                                       mark=(6.0, "6 m")),
            shipped="crosswalk_4cars_satnav_collision6", gif_size=(640, 200)),
)


LIGHTS = ("lights", "lanes", "real-junction")  # behaviours whose scenes have traffic lights
from box2d_driving.envs.single_agent import SHIPPED  # noqa: E402  (assets/policies)


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


def lights_statement(groups: list[Group]) -> list[str]:
    """Plain statements of the lights trends, from the intervals."""
    lines = []
    by_noise: dict[str, dict[float, Estimate]] = defaultdict(dict)
    for g in groups:
        by_noise[g.point.get("lidar_noise", "?")][as_number(g.point.get("num_cars"))] = g.estimates["red_light_violation_rate"]
    for noise in sorted(by_noise, key=as_number):
        cars = by_noise[noise]
        if 1.0 in cars and cars[1.0].high is not None:
            one = cars[1.0]
            ignored = one.contains(0.45)
            lines.append(f"- noise {noise}, 1 car: violations {one.format()}: "
                         + ("the light-blind rate (~0.45) lies in the interval: the light is ignored, as in the paper."
                            if ignored else "the light-blind rate (~0.45) lies outside the interval: the lone car "
                            "reacts to the light, unlike the paper."))
        if 1.0 in cars and len(cars) > 1:
            most = max(cars)
            one, many = cars[1.0], cars[most]
            if one.high is not None and many.high is not None:
                apart = many.high < one.low
                lines.append(f"- noise {noise}: 1 car {one.format()}, {most:g} cars {many.format()}: "
                             + ("fewer violations with more cars, intervals apart." if apart else
                                "the intervals overlap: no difference shown."))
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
             "brackets. How sweeps run: [sweeps.md](sweeps.md).", ""]
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
            parts += ["**Ours.** Not run yet. To run it:", "", "```bash", section.command, "```", ""]
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
                      + f", {summary['sweep']['episodes']} report episodes each).", ""]
            header = [*keys, "seeds", *(label for _, label in section.metrics)]
            parts += ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
            for g in groups:
                cells = [g.point[k] for k in keys] + [str(len(g.seeds))]
                cells += [_estimate_cell(g.estimates[m]) for m in metrics]
                parts.append("| " + " | ".join(cells) + " |")
            parts.append("")
            notes = _comparison(section, groups)
            if section.key == "traffic-lights":
                notes += lights_statement(groups)
            if notes:
                parts += notes + [""]
            if section.figure is not None and groups:
                name = f"{section.key}.png"
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


def _relative(target: Path, start: Path) -> str:
    import os

    return os.path.relpath(Path(target).resolve(), Path(start).resolve())


def main(argv: Optional[list[str]] = None) -> int:
    from training.cli_args import OneLineParser

    p = OneLineParser(prog="box2d-driving reproduce",
               description="Write the results page and its figures from sweep summaries (summary.json).")
    p.add_argument("summaries", nargs="*", type=Path, help="summary.json files of sweeps")
    p.add_argument("--out", type=Path, default=Path("docs/results.md"), help="the page (default docs/results.md)")
    p.add_argument("--figures", type=Path, help="folder for the figures (default: images/results beside the page)")
    p.add_argument("--gifs", action="store_true",
                   help="also redraw each rule's animated GIF of its shipped policy (needs the train extra "
                        "and assets/policies; without it, existing GIFs are linked)")
    args = p.parse_args(argv)
    try:
        summaries = [load_summary(s) for s in args.summaries]
        figures = args.figures or args.out.parent / "images" / "results"
        write_page(summaries, args.out, figures, gifs=args.gifs)
    except ResultsError as exc:
        print(f"box2d-driving reproduce: error: {exc}", file=sys.stderr)
        return 2
    print(f"wrote {args.out} and its figures in {figures}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
