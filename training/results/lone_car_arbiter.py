"""The paper's own trainer on its 1-car run, on the results page: the arbiter of the lone-car claim.

The paper says a lone car "has no need to follow the signals". ``box2d-driving original train
--turns --lidar-noise 0 --seed S`` runs the original's 1-car command (one car on its turning
junction, horizon 20 decisions, entropy 1e-3, 60 epochs of 32,000 joint steps); ``original
evaluate --run`` scores each run's last actor on report episodes of that world, and ``original
evaluate --driver NAME --turns`` the scripted drivers on the same episodes. The rule is the one
the page applies to our lone car: the light is followed only where the interval over seeds of
the runs' red-light violations lies below every rule-free driver's rate (full throttle, uniform
random); anything else is a light not followed, as the paper says. No verdict from fewer than two
finished seeds, nor without a rule-free driver on the runs' episodes.
"""

from __future__ import annotations

from training.common.markdown import anchor, row, separator
from box2d_driving.metrics.stats import mean_ci
from training.results.original_runs import (METRIC, RULE_FREE, DriverReport, OriginalRun, drivers_part, finished,
                                            report_rates, same_episodes)
from training.results.statements import light_followed

__all__ = ["LONE_CAR_TITLE", "lone_car_cell", "lone_car_section", "lone_car_verdict"]

LONE_CAR_TITLE = "The paper's own code on its lone car"
COMMAND = "box2d-driving original train --turns --lidar-noise 0 --seed S --out assets/original/turns_seedS"


def lone_car_verdict(runs: list[OriginalRun], drivers: list[DriverReport]) -> tuple[str, str]:
    """(verdict, words) of the lone-car claim from the finished, evaluated 1-car runs against the
    rule-free drivers of the turning junction on the same episodes, under the page's rule."""
    done = finished(runs)
    seeds = f"seeds finished and evaluated: {len(done)}"
    if not done:
        return "not run yet", f"{seeds}; a verdict needs two"
    _, here = same_episodes(done, drivers, cars=1, turns=True)
    free = {d.driver: d.violations for d in here if d.driver in RULE_FREE}
    if not free:
        return "no reference yet", (f"{seeds}; no rule-free driver scored on their episodes (`box2d-driving original "
                                    f"evaluate --driver full-throttle --turns`)")
    values = [float(r.report[METRIC]) for r in done if r.report]
    if len(values) < 2:
        return "no interval yet", f"{seeds}; an interval needs two"
    e = mean_ci(values, bounds=(0.0, 1.0))
    low, high = e.interval
    them = ", ".join(f"{name} {value:.3f}" for name, value in free.items())
    words = f"{seeds}; 1 car, red-light violations {e.format()} over seeds; on the same episodes {them}"
    follows, reading = light_followed(low, high, min(free.values()), "the")
    return ("opposite" if follows else "reproduced"), f"{words}: {reading}"


def lone_car_cell(runs: list[OriginalRun], drivers: list[DriverReport]) -> str:
    """The claims table's cell for the lone-car claim, where the original's 1-car run was run."""
    verdict, words = lone_car_verdict(runs, drivers)
    return f"**{verdict}** ([{LONE_CAR_TITLE}](#{anchor(LONE_CAR_TITLE)})): {words}"


def lone_car_section(runs: list[OriginalRun], drivers: list[DriverReport]) -> list[str]:
    """The page's section on the original trainer's 1-car runs: the table of runs, the scripted
    drivers on their episodes and the verdict (or how to run it, where no run is carried)."""
    parts = [f"## {LONE_CAR_TITLE}", "",
             "sdriving 0.1.0's own trainer on the original's 1-car command: one car on its turning junction (each "
             "car leaves by one of the three other roads, lights merged into two phases with right-of-way "
             "signals), horizon 20 decisions, LiDAR noise 0, entropy 1e-3, 60 epochs of 32,000 joint steps (1.92 M "
             "decisions of the one car), run by `box2d-driving original train --turns` and carried in "
             "`assets/original/`. Each run's last actor drives that world on 200 report episodes, scored by our "
             "metric code (`box2d-driving original evaluate --run`), beside scripted drivers on the same episodes "
             "(`box2d-driving original evaluate --driver NAME --turns`). Only runs that finished their budget "
             "count towards the verdict.", ""]
    if not runs:
        return parts + [f"No run carried yet: `{COMMAND}` (resumable with `--resume`, `--time-limit` per leg), "
                        "then `box2d-driving original evaluate --run RUN --episodes 200 --out RUN/report.json`.", ""]
    header = ["run", "seed", "epochs done", "joint steps", "evaluated at epoch", "red-light violations", "success",
              "collisions"]
    parts += [row(header), separator(len(header))]
    for r in runs:
        parts.append(row([f"`{r.name}`", str(r.seed), f"{r.epochs_done} of {r.epochs}", f"{r.joint_steps:,}",
                          "-" if r.evaluated_epochs is None else str(r.evaluated_epochs), *report_rates(r)]))
    parts += [""] + drivers_part(runs, drivers, cars=1, turns=True,
                                 all_below="each learnt to stop for the light, unlike the paper")
    verdict, words = lone_car_verdict(runs, drivers)
    return parts + [f"**The lone-car claim, by the paper's own code: {verdict}.** {words[:1].upper()}{words[1:]}.", ""]
