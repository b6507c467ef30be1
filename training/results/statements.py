"""Plain statements on the results page: what our intervals say against the paper's claims.

Each statement is computed from the estimates over training seeds (and, for the lone car at a
light, a light-blind driver on the very same report episodes); none is written by hand.
"""

from __future__ import annotations

import math
from collections import defaultdict
from typing import Callable, Sequence

import numpy as np

from training.common.markdown import all_of
from training.results.data import LEARNT_SUCCESS, SINGLE_POINT, Baseline, Group, Metric, PaperValue, as_number
from box2d_driving.metrics.stats import Estimate, mean_ci, p_text, t_test_p, welch_p
from training.results.seed_counts import paired_differences, seeds_needed, seeds_needed_apart

# the sections name their statements and gather them (``sections.statements``): this module never
# imports the sections
__all__ = ["Statement", "above_statement", "apart_statement", "level_change_statement", "lights_statement",
           "lone_car_statement", "noise_trend_statement", "paper_comparison", "reference_statement",
           "unlearnt_statement"]

# a section's own statements: from its grouped trials and its baseline's measurements, the lines
# it adds to the page
Statement = Callable[[list[Group], Baseline], list[str]]


def _where(point: dict[str, str]) -> str:
    return ", ".join(f"{k}={v}" for k, v in point.items()) or SINGLE_POINT


def _unlearnt(g: Group) -> bool:
    """Whether the cars of this grid point mostly fail to arrive (mean success below LEARNT_SUCCESS)."""
    e = g.estimates.get("success_rate")
    return e is not None and bool(e.n) and e.mean < LEARNT_SUCCESS


def apart(a: Estimate, b: Estimate) -> int:
    """How ``b`` lies against ``a`` by their intervals: 1 above and apart, -1 below and apart, 0
    overlapping."""
    (a_low, a_high), (b_low, b_high) = a.interval, b.interval
    return 1 if b_low > a_high else -1 if b_high < a_low else 0


def paper_comparison(paper_values: Sequence[PaperValue], groups: list[Group]) -> list[str]:
    """Our estimate against each of the paper's numbers, per grid point. A number the paper gives
    with a +- spread (a spread over its runs, not a confidence interval) is compared with our mean;
    a single number with our interval, the seeds on each side of it and a one-sample t-test."""
    lines = []
    for pv in paper_values:
        for g in groups:
            e = g.estimates.get(pv.metric)
            if e is None or e.n == 0:
                continue
            where = _where(g.point)
            if pv.spread is not None:
                inside = abs(e.mean - pv.value) <= pv.spread
                lines.append(f"- {pv.metric} ({where}): ours {e.format()} against the paper's {pv.text} (a "
                             f"spread over the paper's runs, not a confidence interval): our mean is "
                             f"{'inside' if inside else 'outside'} that spread.")
                continue
            lines.append(f"- {pv.metric} ({where}): ours {e.format()} against the paper's {pv.text}: "
                         f"{_against_value(e, pv.value)}.")
    return lines


def _against_value(e: Estimate, value: float) -> str:
    """Our seeds against one number: the interval, how many seeds lie on each side, the test."""
    if e.low is None:
        return "one seed only: no interval"
    below = sum(v < value for v in e.values)
    above = sum(v > value for v in e.values)
    every = all_of(e.n, "seed", "seeds")
    sides = (f"{every} below it" if below == e.n else f"{every} above it" if above == e.n
             else f"{below} of {e.n} seeds below it, {above} above")
    p = t_test_p(e.values, value)
    where = "inside" if e.contains(value) else "outside"
    more = seeds_needed([v - value for v in e.values]) if e.contains(value) else ""
    return f"the paper's value lies {where} our interval; {sides}; one-sample t-test {p_text(p)}{more}"


def more_cars_verdict(fewer: Estimate, more: Estimate) -> str:
    """The paper's first lights trend (more cars, fewer violations) read from the two intervals."""
    return {-1: "fewer violations with more cars, intervals apart, as in the paper.",
            1: "more violations with more cars, intervals apart, unlike the paper.",
            0: f"the intervals overlap: no difference detected; they allow a fall of up to "
               f"{max(0.0, fewer.interval[1] - more.interval[0]):.3f}."}[apart(fewer, more)]


def by_verdict(subject: str, readings: list[tuple[str, str, str]]) -> list[str]:
    """One line per verdict for readings ``(noise, numbers, verdict)`` of one comparison across noise
    levels, so four levels that agree make one line, not four."""
    grouped: dict[str, list[str]] = defaultdict(list)
    for noise, numbers, verdict in readings:
        grouped[verdict].append(f"noise {noise} {numbers}")
    every = len(readings) > 1
    return [f"- {subject}{', every noise level' if every and len(parts) == len(readings) else ''}: "
            f"{'; '.join(parts)}: {verdict}" for verdict, parts in grouped.items()]


def lights_statement(groups: list[Group], blind: Baseline) -> list[str]:
    """Plain statements of the lights trends, from the intervals. ``blind``: per noise level, the
    light-blind driver's violation rate on the same report episodes and its number of entries."""
    by_noise: dict[str, dict[float, Estimate]] = defaultdict(dict)
    by_cars: dict[float, list[Group]] = defaultdict(list)
    # a grid point not learnt at this budget is said once by unlearnt_statement, compared with nothing
    for g in (g for g in groups if not _unlearnt(g)):
        n_cars = as_number(g.point.get("num_cars"))
        by_noise[g.point.get("lidar_noise", "?")][n_cars] = g.estimates["red_light_violation_rate"]
        by_cars[n_cars].append(g)
    lone: list[tuple[str, str, str]] = []
    against: dict[float, list[tuple[str, str, str]]] = defaultdict(list)
    for noise in sorted(by_noise, key=as_number):
        cars, one = by_noise[noise], by_noise[noise].get(1.0)
        if one is not None and noise in blind and one.n:
            rate, entries = blind[noise]
            # the blind rate is itself measured on `entries` junction entries: its 95 % binomial margin
            margin = 1.96 * math.sqrt(max(rate * (1 - rate), 1e-12) / max(entries, 1))
            lone.append((noise, f"{one.format()} against {rate:.3f} ± {margin:.3f}",
                         "no different: the light is ignored, as in the paper." if abs(one.mean - rate) <= margin else
                         "different: the lone car reacts to the light, unlike the paper."))
        for n in sorted(c for c in cars if c > 1.0):
            if one is not None and one.high is not None and cars[n].high is not None:
                against[n].append((noise, f"{one.format()} against {cars[n].format()}",
                                   more_cars_verdict(one, cars[n])))
    lines = by_verdict("1 car, red-light violations against a light-blind driver (full throttle) on the same "
                       "episodes", lone)
    for n, readings in sorted(against.items()):
        lines += by_verdict(f"red-light violations, 1 car against {n:g} cars", readings)
    # the paper's second trend: with more LiDAR noise, fewer violations (at each number of cars)
    for n in sorted(c for c in by_cars if c > 1.0):
        lines += noise_trend(by_cars[n], [("red_light_violation_rate", f"{n:g} cars, red-light violations")], paper=-1)
    return lines


def noise_trend_statement(metrics: tuple[tuple[Metric, str], ...], paper: int = 1) -> Statement:
    """States :func:`noise_trend` for (metric, label) pairs."""
    return lambda groups, baseline: noise_trend(groups, list(metrics), paper)


def noise_trend(groups: list[Group], metrics: list[tuple[Metric, str]], paper: int = 1) -> list[str]:
    """Whether each metric rises or falls from the lowest to the highest LiDAR noise, from the
    intervals; ``paper``: the direction the paper reports (1 rises, -1 falls)."""
    by_noise = sorted((g for g in groups if "lidar_noise" in g.point), key=lambda g: as_number(g.point["lidar_noise"]))
    if len(by_noise) < 2:
        return []
    lines = [change_line(by_noise[0], by_noise[-1], "lidar_noise", metric, label, paper) for metric, label in metrics]
    return [line for line in lines if line]


# how a grid key's levels are named in a change's sentence ("noise 0 ..., noise 0.5 ...")
LEVEL_NAMES = {"lidar_noise": "noise"}


def change_line(low: Group, high: Group, key: str, metric: Metric, label: str, paper: int) -> str:
    """One line: whether ``metric`` rises or falls from ``low`` to ``high`` (two levels of ``key``),
    paired by seed where both have the same seeds, else from the intervals. ``paper``: the
    direction the paper reports (1 rises, -1 falls), or 0 where it gives none for these two levels
    (then no verdict names the paper). Empty where either level has no interval."""
    a, b = low.estimates[metric], high.estimates[metric]
    if a.high is None or b.high is None:
        return ""
    name = LEVEL_NAMES.get(key, key)
    diffs = paired_differences(low, high, metric)
    paired = len(diffs) >= 2  # the same seeds at both levels: a paired test
    if paired:
        d, p = mean_ci(diffs), t_test_p(diffs, 0.0)
        d_low, d_high = d.interval
        seen = 0 if d_low <= 0.0 <= d_high else (1 if d.mean > 0 else -1)
        how = (f"paired by seed ({len(diffs)} seeds), high minus low {name} {d.mean:+.3f} ± "
               f"{(d_high - d_low) / 2:.3f}, {p_text(p)}")
        moved, unmoved, more = f", {how}", f" detected ({how})", seeds_needed(diffs)
        allows = d_high if paper > 0 else -d_low  # the largest effect the paper's way the interval keeps
    else:
        seen = apart(a, b)
        moved, unmoved, more = ", intervals apart", " detected", ""
        allows = b.interval[1] - a.interval[0] if paper > 0 else a.interval[1] - b.interval[0]
    expected = ("rise" if paper > 0 else "fall") if paper else "change"
    if seen:
        verdict = ("rises" if seen > 0 else "falls") + moved + (
            "" if not paper else ", as in the paper" if seen == paper else ", unlike the paper")
    else:
        verdict = ("" if paired else "the intervals overlap: ") + f"no {expected}{unmoved}" + (
            f"; the interval allows a {expected} of up to {max(0.0, allows):.3f}" if paper else ""
        ) + _seeds_the_papers_way(diffs if paired else [], paper)
        verdict += more  # how many seeds would tell
    return f"- {label}: {name} {low.point[key]} {a.format()}, {name} {high.point[key]} {b.format()}: {verdict}."


def _seeds_the_papers_way(diffs: Sequence[float], paper: int) -> str:
    """Where a paired difference is not shown: how many seeds moved the way the paper reports, in
    words, so "3 of 3 seeds rise" stands beside an interval that straddles zero (a seed whose
    difference is exactly zero moved neither way); "" without pairs or a reported direction."""
    if not diffs or not paper:
        return ""
    k = sum(1 for d in diffs if d * paper > 0)
    return f"; {k} of {len(diffs)} seeds {'rise' if paper > 0 else 'fall'}"


def _slices(groups: list[Group], key: str) -> dict[tuple[tuple[str, str], ...], dict[str, Group]]:
    """``groups`` by the values of every grid key but ``key``, then by ``key``'s value."""
    out: dict[tuple[tuple[str, str], ...], dict[str, Group]] = defaultdict(dict)
    for g in groups:
        if key in g.point:
            out[tuple((k, v) for k, v in g.point.items() if k != key)][g.point[key]] = g
    return out


def level_change_statement(key: str, low: str, high: str, metrics: tuple[tuple[Metric, str], ...], paper: int,
                           paper_words: str = "") -> Statement:
    """:func:`change_line` from ``key=low`` to ``key=high`` for each (metric, label), at every
    setting of the other grid keys that has both levels (paired by seed where the seeds match).
    ``paper_words``: what the paper says of these two levels, added after the lines (needed where
    ``paper`` is 0)."""
    def say(groups: list[Group], baseline: Baseline) -> list[str]:
        lines = []
        for rest, levels in _slices(groups, key).items():
            if low in levels and high in levels:
                where = f"{_where(dict(rest))}, " if rest else ""
                lines += [change_line(levels[low], levels[high], key, m, f"{where}{label}", paper)
                          for m, label in metrics]
        lines = [line for line in lines if line]
        return lines + [f"- {paper_words}"] if lines and paper_words else lines
    return say


def unlearnt_statement(groups: list[Group]) -> list[str]:
    """Grid points whose cars mostly fail to arrive: their rule measures say little. Points that
    differ only in LiDAR noise share a line."""
    rows: dict[str, list[Group]] = defaultdict(list)
    for g in (g for g in groups if _unlearnt(g)):
        rows[_where({k: v for k, v in g.point.items() if k != "lidar_noise"})].append(g)
    lines = []
    for where, same in rows.items():
        if len(same) == 1:
            success = f"{_where(same[0].point)}: success {same[0].estimates['success_rate'].format()}"
        else:
            success = f"{where}: success " + "; ".join(f"noise {g.point['lidar_noise']} "
                                                       f"{g.estimates['success_rate'].format()}" for g in same)
        lines.append(f"- {success}: at this budget the cars have not learnt to reach their goals, so the other "
                     f"numbers of {'this row' if len(same) == 1 else 'these rows'} say little about the rule.")
    return lines


def apart_statement(key: str, few: str, many: str, metric: Metric, label: str, claim: str,
                    judged: bool = True) -> Statement:
    """Whether ``metric`` is larger at ``key=many`` than at ``key=few``, from the intervals, at every
    setting of the other grid keys (each named in its line); ``claim``: the paper's reading of
    that, in words. ``judged=False``: the difference alone is not the paper's claim (the paper says
    more, stated elsewhere), so no verdict names the paper."""
    def say(groups: list[Group], baseline: Baseline) -> list[str]:
        lines = []
        for rest, by in _slices(groups, key).items():
            if few not in by or many not in by:
                continue
            a, b = by[few].estimates[metric], by[many].estimates[metric]
            if a.high is None or b.high is None:
                continue
            paper = (", as in the paper", ", unlike the paper") if judged else ("", "")
            # an overlap says how many seeds per row the observed difference would need (item: add
            # seeds where an interval straddles the comparison, or say how many)
            verdict = {1: f"{claim}, intervals apart{paper[0]}.",
                       0: f"the intervals overlap: no difference detected"
                          f"{seeds_needed_apart(a.values, b.values)}.",
                       -1: f"the opposite of {claim}, intervals apart{paper[1]}."}[apart(a, b)]
            where = f" ({_where(dict(rest))})" if rest else ""
            lines.append(f"- {label}{where}: {key}={few} {a.format()}, {key}={many} {b.format()}: {verdict}")
        return lines
    return say


def above_statement(metric: Metric, label: str, above: str, below: str, level: float = 0.5,
                    level_text: str = "one half", paper: str = "") -> Statement:
    """Whether ``metric`` is above ``level`` at every grid point, from the intervals; ``above`` (the
    paper's reading) and ``below``: what each side means, in words. ``paper``: what the paper says
    of it where that is not simply "above" at every grid point (then no verdict claims the paper's
    agreement; the sentence is added instead)."""
    def say(groups: list[Group], baseline: Baseline) -> list[str]:
        lines = []
        for g in groups:
            e = g.estimates[metric]
            if e.high is None:
                continue
            # a straddle says how many seeds the seeds' distance from the level would need
            straddle = (f"the interval straddles {level_text}: neither shown"
                        f"{seeds_needed([v - level for v in e.values])}.")
            low, high = e.interval
            if paper:
                verdict = f"{above}." if low > level else f"{below}." if high < level else straddle
            else:
                verdict = (f"{above}, as in the paper." if low > level else
                           f"{below}, unlike the paper." if high < level else straddle)
            lines.append(f"- {label} ({_where(g.point)}): {e.format()}: {verdict}")
        if paper and lines:
            lines.append(f"- {paper}")
        return lines
    return say


def reference_statement(groups: list[Group], reference: Group, label: str, more_cars_here: bool = True) -> list[str]:
    """This section's violations against a reference grid point with fewer cars (the paper: more
    cars, fewer violations), from the intervals; ``more_cars_here=False``: the reference has more
    cars than this section (a lone car set against the 4-car row)."""
    metric = "red_light_violation_rate"
    ref = reference.estimates.get(metric)
    lines = []
    for g in groups:
        e = g.estimates.get(metric)
        if e is None or ref is None or e.high is None or ref.high is None:
            continue
        fewer_cars, more_cars = (ref, e) if more_cars_here else (e, ref)
        verdict = more_cars_verdict(fewer_cars, more_cars)
        these = "these trials" if not g.point else f"these trials at {_where(g.point)}"
        # the two rows' seeds were not trained in pairs: Welch's two-sample test
        p = welch_p(e.values, ref.values)
        if p is None:  # not reached: both rows have 2+ seeds here (an interval each)
            continue
        test = f" (Welch's t-test {p_text(p)}"
        if apart(ref, e) == 0:
            if p < 0.05:
                # two 95 % intervals of the means may overlap while their difference is still
                # significant: the test of the difference decides, and the page says so
                fewer = more_cars.mean < fewer_cars.mean
                verdict = (f"{'fewer' if fewer else 'more'} violations with more cars by Welch's test, "
                           f"though the two intervals overlap, {'as' if fewer else 'unlike'} the paper.")
            else:
                test += seeds_needed_apart(e.values, ref.values)
        lines.append(f"- red-light violations: {these} {e.format()}, {label} {ref.format()}: "
                     f"{verdict.rstrip('.')}{test}).")
    return lines


def light_followed(low: float, high: float, lowest: float, whose: str) -> tuple[bool, str]:
    """Whether a lone car's violations interval ``[low, high]`` lies below ``lowest``, the lowest
    rule-free scripted driver's rate on the same episodes (the light followed, unlike the paper),
    and the words for it; ``whose``: how the words name the interval ("our", "the")."""
    if high < lowest:
        return True, "below every rule-free driver: the lone car stops for the light, unlike the paper"
    return False, (f"not below every rule-free driver ({whose} interval reaches down to {max(low, 0.0):.3f}): the "
                   "light is not followed, as in the paper")


def lone_car_statement(groups: list[Group], baseline: Baseline) -> list[str]:
    """The paper's lone car: "in a single agent environment, there is no need to follow the
    signals". A car follows the light only where its violations' interval lies below every
    rule-free scripted driver's rate on the same report episodes (``baseline``, keyed
    ``DRIVER/red_light_violation_rate``: full throttle, which never sees the light, and uniform
    random actions); anything else is a light not followed, as the paper says. Where the interval
    is wide, the line gives how far down it reaches, so a reader sees what "not followed" rests on."""
    metric = "red_light_violation_rate"
    drivers = {key.split("/", 1)[0]: value for key, (value, _) in baseline.items()
               if key.split("/", 1)[1] == metric and np.isfinite(value)}
    if not drivers:
        return []
    episodes = next(count for key, (_, count) in baseline.items() if key.split("/", 1)[0] in drivers)
    lines = []
    for g in groups:
        e = g.estimates.get(metric)
        if e is None or e.high is None:
            continue
        low, high = e.interval
        them = ", ".join(f"{d} {v:.3f}" for d, v in drivers.items())
        lowest = min(drivers.values())
        _, verdict = light_followed(low, high, lowest, "our")
        # seeds that all score the same leave an interval of no width: say so, and what it leaves out
        same = (f" (all {e.n} seeds scored {e.mean:.3f} on these episodes: the interval over seeds has no width, and "
                f"the episodes' own sampling error is not in it)" if len(set(e.values)) == 1 else "")
        lines.append(f"- 1 car, red-light violations against rule-free scripted drivers on the same {episodes} report "
                     f"episodes ({_where(g.point)}): ours {e.format()}{same}; {them}: {verdict}.")
    return lines


def scripted_baseline_statement(metrics: tuple[tuple[Metric, str], ...], paper: int = 1,
                                references: tuple[str, ...] = (), claimed: bool = True) -> Statement:
    """Our estimate of each metric against the scripted drivers' values on the same report episodes
    (the section's baseline, keyed ``DRIVER/METRIC``, or ``DRIVER/METRIC@num_cars=N`` where its
    grid points differ in car count): a rule counts as learnt only where our interval lies beyond
    every rule-free scripted driver's value in the rule's direction (``paper``: 1, higher is the
    rule; -1, lower). ``references``: drivers that follow a scripted rule (or see what the policy
    cannot), given for comparison but not part of the verdict. ``claimed``: whether the paper
    claims the rule at every grid point (else the line says what is learnt, and the section's
    other statements compare with the paper)."""
    def drivers_for(baseline: Baseline, metric: Metric, point: dict[str, str]) -> dict[str, tuple[float, int]]:
        cars = f"num_cars={int(as_number(point['num_cars']))}" if "num_cars" in point else None
        out = {}
        for key, value in baseline.items():
            driver, measure = key.split("/", 1)
            name, _, condition = measure.partition("@")
            if name == str(metric) and (not condition or condition == cars) and np.isfinite(value[0]):
                out[driver] = value  # a driver without a value (nothing varies: no correlation) is left out
        return out

    def say(groups: list[Group], baseline: Baseline) -> list[str]:
        lines = []
        for metric, label in metrics:
            for g in groups:
                scored = drivers_for(baseline, metric, g.point)
                drivers = {d: v for d, (v, _) in scored.items() if d not in references}
                shown = {d: v for d, (v, _) in scored.items() if d in references}
                e = g.estimates.get(metric)
                if not drivers or e is None or e.high is None:
                    continue
                episodes = next(iter(scored.values()))[1]
                low, high = e.interval
                beyond = [d for d, v in drivers.items() if (low > v if paper > 0 else high < v)]
                behind = [d for d, v in drivers.items() if (high < v if paper > 0 else low > v)]
                them = ", ".join(f"{d} {v:.3f}" for d, v in drivers.items())
                if shown:
                    them += " (for comparison, " + ", ".join(f"{d} {v:.3f}" for d, v in shown.items()) + ")"
                if len(beyond) == len(drivers):
                    verdict = ("beyond every scripted driver: the rule is learnt, as in the paper" if claimed
                               else "beyond every scripted driver: learnt")
                elif behind:
                    side = "below" if paper > 0 else "above"
                    verdict = f"{side} {' and '.join(behind)}: " + ("no rule learnt, unlike the paper" if claimed
                                                                     else "not learnt")
                else:
                    inside = [d for d in drivers if d not in beyond]
                    verdict = f"no learnt rule detected (the interval holds {' and '.join(inside)})"
                lines.append(f"- {label} against scripted drivers on the same {episodes} report episodes "
                             f"({_where(g.point)}): ours {e.format()}; {them}: {verdict}.")
        return lines
    return say
