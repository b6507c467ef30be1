"""The paper's own trainer in its own world, on the results page: the arbiter of the noise claim.

``box2d-driving original train`` runs sdriving 0.1.0's trainer on the original command (its
world, its update, its budget in epochs of 32,000 joint steps); the runs carried in
``assets/original/<run>/`` are scored on report episodes by our metric code
(``box2d-driving original evaluate --run assets/original/<run> --episodes 200 --out
assets/original/<run>/report.json``). This module reads them and says what they say about the
paper's claim that more LiDAR noise means fewer red-light violations: per run its numbers, per
noise level the mean over seeds, and between the paper's two ends (0.25 and 1.0) the paired
difference by seed with its 95 % interval, under the page's one verdict rule. No verdict from
fewer than two seeds at each end.
"""

from __future__ import annotations

from pathlib import Path
from typing import Optional

from training.common.markdown import anchor, row, separator
from box2d_driving.metrics.stats import mean_ci, p_text, t_test_p
from training.results.original_runs import (METRIC, ORIGINAL_RUNS, DriverReport, OriginalRun, drivers_part,
                                            finished, load_driver_reports, load_original_runs, report_rates)
from training.results.seed_counts import seeds_needed

__all__ = ["ARBITER_TITLE", "ORIGINAL_RUNS", "DriverReport", "OriginalRun", "arbiter_cell", "arbiter_section",
           "load_driver_reports", "load_original_runs", "training_curve_figure"]

ARBITER_TITLE = "The paper's own code, in its own world"
LOW, HIGH = 0.25, 1.0  # the paper's noise runs at the two ends (75 and 50 epochs)
CURVE_FIGURE = "original_training.png"


def training_curve_figure(runs: list[OriginalRun], path: Path) -> bool:
    """The runs' training curves (mean episode return per epoch against joint steps, one line per
    run, coloured by LiDAR noise) and, where runs have one, their kept actors' red-light
    violations on selection episodes beside them; written to ``path``; False where no run logged
    a training curve."""
    drawn = [r for r in runs if r.curve]
    if not drawn:
        return False
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    colours = {noise: plt.get_cmap("tab10")(k) for k, noise in enumerate(sorted({r.lidar_noise for r in drawn}))}
    measured = [r for r in drawn if r.violations]
    fig, axes = plt.subplots(1, 2 if measured else 1, figsize=(11.0 if measured else 7.0, 4.0), squeeze=False)
    ax = axes[0][0]
    for r in drawn:
        steps, returns = zip(*r.curve)
        ax.plot([s / 1e6 for s in steps], returns, color=colours[r.lidar_noise], lw=1.2,
                ls="-" if r.epochs_done == r.epochs else "--",
                label=f"noise {_noise(r.lidar_noise)}, seed {r.seed} ({r.epochs_done} of {r.epochs} epochs)")
    ax.set_xlabel("joint steps (millions; 32,000 per epoch)")
    ax.set_ylabel("mean episode return in the epoch")
    ax.set_title("The paper's own trainer, 4 cars: training curves")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8, loc="lower right")
    if measured:
        ax = axes[0][1]
        for r in measured:
            steps, values = zip(*r.violations)
            ax.plot([s / 1e6 for s in steps], values, "o-", color=colours[r.lidar_noise], lw=1.2, ms=3,
                    label=f"noise {_noise(r.lidar_noise)}, seed {r.seed}")
        ax.set_xlabel("joint steps (millions)")
        ax.set_ylabel("red-light violations")
        ax.set_title("kept actors on selection episodes")
        ax.set_ylim(0, None)
        ax.set_xlim(axes[0][0].get_xlim())  # the same joint steps as the training curves beside it
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return True


def _noise(value: float) -> str:
    """A noise level as the page writes it (1.0, 0.25)."""
    return f"{value:.1f}" if value == int(value) else f"{value:g}"


def _evaluated(runs: list[OriginalRun], noise: float) -> dict[int, float]:
    """Seed -> violations of the runs at ``noise`` that finished their budget and were evaluated
    at their last epoch."""
    return {r.seed: float(r.report[METRIC]) for r in finished(runs) if r.lidar_noise == noise and r.report}


def noise_verdict(runs: list[OriginalRun]) -> tuple[str, str]:
    """(verdict, words) of the noise claim from the finished, evaluated runs: the difference high
    minus low noise paired by seed (seeds run at both ends), under the page's rule; "not run yet"
    or "no interval yet" with fewer than two such seeds."""
    low, high = _evaluated(runs, LOW), _evaluated(runs, HIGH)
    paired = sorted(set(low) & set(high))
    ends = f"seeds finished and evaluated at noise {LOW:.2f}: {len(low)}, at noise {HIGH:.1f}: {len(high)}"
    if not low or not high:
        return "not run yet", f"{ends}; a verdict needs both ends"
    if len(paired) < 2:
        return "no interval yet", f"{ends}; an interval needs two seeds run at both ends"
    diffs = [high[s] - low[s] for s in paired]
    diff = mean_ci(diffs, bounds=(-1.0, 1.0))
    falls = sum(d < 0 for d in diffs)
    words = (f"{ends}; paired by seed ({len(paired)} seeds), high minus low noise {diff.format()}, "
             f"{p_text(t_test_p(diffs, 0.0))}; {falls} of {len(paired)} seeds fall")
    low_end, high_end = diff.interval
    if high_end < 0:
        return "reproduced", words + ": fewer violations with more noise, as in the paper"
    if low_end > 0:
        return "opposite", words + ": more violations with more noise, unlike the paper"
    return "not detected", (words + f": no fall detected; the interval allows a fall of up to {-low_end:.3f}"
                            + seeds_needed(diffs))


def arbiter_cell(runs: list[OriginalRun]) -> str:
    """The claims table's cell for the noise claim: the verdict and what it rests on."""
    verdict, words = noise_verdict(runs)
    return f"**{verdict}** ([{ARBITER_TITLE}](#{anchor(ARBITER_TITLE)})): {words}"


def arbiter_section(runs: list[OriginalRun], figures: Optional[Path] = None, rel: str = "images/results",
                    drivers: tuple[DriverReport, ...] | list[DriverReport] = ()) -> list[str]:
    """The page's section on the original trainer's runs: the table of runs, the scripted
    drivers on the same episodes (``drivers``, :func:`load_driver_reports`), their training
    curves (drawn into ``figures``, linked as ``rel``/..., where ``figures`` is given) and the
    verdict."""
    parts = [f"## {ARBITER_TITLE}", "",
             "sdriving 0.1.0's own trainer (`agents/ppo_distributed/ppo.py`, in one process: see "
             "[paper_world.md](paper_world.md)) on the original command for each noise level (4 cars; 75 epochs of "
             "32,000 joint steps at noise 0.25, 50 at noise 1.0; every car decides at every step and an arrived "
             "car stays), run by `box2d-driving original train` and carried in `assets/original/`. Each run's "
             "actor at its last epoch drives the original world on 200 report episodes, scored by our metric code "
             "(`box2d-driving original evaluate`); rates with their 95 % interval over those episodes (episodes as "
             "clusters). Only runs that finished their budget count towards the verdict.", ""]
    if not runs:
        return parts + ["No run carried yet.", ""]
    header = ["run", "LiDAR noise", "seed", "epochs done", "joint steps", "car-decisions", "evaluated at epoch",
              "red-light violations", "success", "collisions"]
    parts += [row(header), separator(len(header))]
    for r in runs:
        parts.append(row([f"`{r.name}`", _noise(r.lidar_noise), str(r.seed), f"{r.epochs_done} of {r.epochs}",
                          f"{r.joint_steps:,}", f"{r.car_decisions:,}",
                          "-" if r.evaluated_epochs is None else str(r.evaluated_epochs), *report_rates(r)]))
    parts += [""] + drivers_part(runs, list(drivers), cars=4, turns=False,
                                 all_below="the paper's code learns to stop at red at every noise level it ran")
    verdict, words = noise_verdict(runs)
    parts += [f"**The noise claim, by the paper's own code: {verdict}.** {words[:1].upper()}{words[1:]}.", ""]
    if figures is not None and training_curve_figure(runs, figures / CURVE_FIGURE):
        parts += [f"![The original trainer's training curves]({rel}/{CURVE_FIGURE})", "",
                  "*Left: each run's mean episode return per epoch, from the trainer's own log "
                  "(`progress.csv`), against joint steps; dashed: a run still short of its budget. Right, where "
                  "drawn: the actors a run kept, each on the same selection episodes (`box2d-driving original "
                  "curve`; selection seeds, so that reading the curve chooses nothing on report episodes). The "
                  "violations in the table are measured on report episodes at the evaluated epoch.*", ""]
    return parts
