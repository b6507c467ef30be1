"""Learning curves on the results page: a sweep's checkpoints on selection seeds (``box2d-driving
curve SWEEP``, committed beside its summary as ``curves/NAME.csv``), drawn against decisions,
and whether each rule metric had stopped moving by the end of the trials' budget.

A grid point's metric has *stopped moving* when its late change (how much it moved over the last
half of training, :func:`training.evaluation.checkpoint_curve.late_change`, per seed) has a 95 %
interval over seeds that contains zero and is narrower than +-:data:`PLATEAU_TOLERANCE`; it is
*still moving* when the interval lies on one side of zero, and *too noisy to tell* when it
contains zero but is wider. Both rules were fixed before the paper-settings runs were looked at.
"""

from __future__ import annotations

import csv
import math
from collections import defaultdict
from pathlib import Path
from typing import Any, Optional

import numpy as np

from training.evaluation.checkpoint_curve import LATE_SHARE, late_change
from training.results.data import ResultsError, as_number
from training.results.figures import _plt
from box2d_driving.metrics.stats import Estimate, half_width, mean_ci, mean_var

__all__ = ["PLATEAU_TOLERANCE", "STOPPED", "TOO_NOISY", "curves_path", "curve_figure", "late_changes", "load_curves",
           "plateau_lines", "plateau_verdict", "seeds_to_settle", "settle_words"]

# a late change interval within +-2 points of a share around zero counts as stopped
PLATEAU_TOLERANCE = 0.02


def curves_path(summary_path: Path) -> Path:
    """Where a summary's curves are committed: ``curves/NAME.csv`` beside ``NAME.json``."""
    summary_path = Path(summary_path)
    return summary_path.parent / "curves" / f"{summary_path.stem}.csv"


def load_curves(path: Path, keys: list[str], trials: Optional[set[str]] = None) -> Optional[list[dict[str, Any]]]:
    """The curve rows of a sweep (None where none are committed, or none of ``trials`` when it is
    given), numbers as floats, the grid values (``keys``) as typed; :class:`ResultsError` for a
    file that is not a sweep's curves."""
    if not Path(path).exists():
        return None
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    missing = [k for k in ("seed", "decisions", *keys) if rows and k not in rows[0]]
    if not rows or missing:
        raise ResultsError(f"{path}: not a sweep's curves (missing columns: {', '.join(missing) or 'all rows'})")
    if trials is not None:
        if "trial" not in rows[0]:
            raise ResultsError(f"{path}: not a sweep's curves (missing columns: trial)")
        rows = [r for r in rows if r["trial"] in trials]
        if not rows:
            return None
    out = []
    for r in rows:
        row: dict[str, Any] = {k: r[k] for k in keys}
        row["seed"] = int(r["seed"])
        for k, v in r.items():
            if k not in keys and k not in ("trial", "seed"):
                row[k] = float(v) if v not in ("", None) else float("nan")
        out.append(row)
    return out


def _by_point(rows: list[dict[str, Any]], keys: list[str]) -> dict[tuple, dict[int, list[dict]]]:
    """Grid point -> seed -> that trial's rows in training order."""
    found: dict[tuple, dict[int, list[dict]]] = defaultdict(lambda: defaultdict(list))
    for r in rows:
        found[tuple(r[k] for k in keys)][r["seed"]].append(r)
    for seeds in found.values():
        for trial in seeds.values():
            trial.sort(key=lambda r: r["decisions"])
    return dict(sorted(found.items(), key=lambda kv: tuple(as_number(v) for v in kv[0])))


def late_changes(rows: list[dict[str, Any]], keys: list[str], metric: str) -> dict[tuple, Estimate]:
    """Per grid point: ``metric``'s late change per seed, estimated over seeds."""
    return {point: mean_ci(late_change(np.array([r["decisions"] for r in trial]), np.array([r[metric] for r in trial]))
                           for trial in seeds.values())
            for point, seeds in _by_point(rows, keys).items()}


STOPPED, TOO_NOISY = "stopped moving", "too noisy to tell"


def plateau_verdict(late: Estimate) -> Optional[str]:
    """A grid point's late change read as :data:`STOPPED`, :data:`TOO_NOISY`, "still rising" or
    "still falling" (the rules in this module's docstring); None for one seed (no interval)."""
    if late.low is None or late.high is None:
        return None
    if late.low <= 0.0 <= late.high:
        return STOPPED if (late.high - late.low) / 2 <= PLATEAU_TOLERANCE else TOO_NOISY
    return "still rising" if late.mean > 0 else "still falling"


def seeds_to_settle(late: Estimate, most: int = 200) -> Optional[int]:
    """How many seeds a grid point's late change (its per-seed spread taken as true) would need for
    a 95 % interval no wider than ±:data:`PLATEAU_TOLERANCE`, the width "stopped moving" asks
    for; None with fewer than two seeds or where more than ``most`` would be needed."""
    if len(late.values) < 2:
        return None
    sd = math.sqrt(mean_var(late.values)[1])
    return next((k for k in range(2, most + 1) if half_width(sd, k) <= PLATEAU_TOLERANCE), None)


def settle_words(needed: list[Optional[int]], most: int = 200) -> str:
    """``seeds_to_settle`` of one or more grid points in words: "about 28 seeds", "about 12-28
    seeds per grid point", or "more than 200 seeds" where any point would need more; ``needed``
    must not be empty."""
    known = [k for k in needed if k is not None]
    if len(known) < len(needed):
        return f"more than {most} seeds"
    low, high = min(known), max(known)
    return f"about {low} seeds" if low == high else f"about {low}-{high} seeds per grid point"


def plateau_lines(rows: list[dict[str, Any]], keys: list[str], metrics: list[tuple[str, str]]) -> list[str]:
    """One statement per metric: at each grid point how much it moved over the last half of
    training (mean ± 95 % half-width over seeds) and whether it had stopped moving."""
    last = max(r["decisions"] for r in rows)
    lines = []
    for metric, label in metrics:
        if metric not in rows[0]:
            continue
        parts = []
        for point, e in late_changes(rows, keys, metric).items():
            where = ", ".join(f"{k} {v}" for k, v in zip(keys, point)) or "every trial"
            verdict = plateau_verdict(e)
            if verdict is None:  # its format says "(1 seed)": no interval, no verdict
                parts.append(f"{where} {e.format()}")
                continue
            if verdict == TOO_NOISY:
                verdict += (f": the interval is wider than ±{PLATEAU_TOLERANCE:g}; at this spread "
                            f"{settle_words([seeds_to_settle(e)])} would narrow it that far")
            parts.append(f"{where} {e.format()} ({verdict})")
        lines.append(f"- {label}, change over the last {LATE_SHARE * 100:.0f} % of training (the last "
                     f"{LATE_SHARE * last / 1e6:.2f} M decisions; least-squares line through the checkpoints, per "
                     f"seed): " + "; ".join(parts) + ".")
    return lines


def curve_figure(rows: list[dict[str, Any]], keys: list[str], metrics: list[tuple[str, str]], path: Path) -> None:
    """One panel per metric against decisions: per grid point the mean over seeds (thick) and
    each seed (thin), every checkpoint on the same selection episodes."""
    metrics = [(m, label) for m, label in metrics if m in rows[0]]
    plt = _plt()
    fig, axes = plt.subplots(1, len(metrics), figsize=(4.4 * len(metrics), 3.6), squeeze=False)
    points = _by_point(rows, keys)
    cmap = plt.get_cmap("viridis")
    for ax, (metric, label) in zip(axes[0], metrics):
        for i, (point, seeds) in enumerate(points.items()):
            colour = cmap(0.85 * i / max(len(points) - 1, 1))
            common = sorted(set.intersection(*(set(r["decisions"] for r in t) for t in seeds.values())))
            for trial in seeds.values():
                ax.plot([r["decisions"] / 1e6 for r in trial], [r[metric] for r in trial], color=colour, lw=0.7,
                        alpha=0.45)
            if common:
                at = {s: {r["decisions"]: r[metric] for r in t} for s, t in seeds.items()}
                means = [np.nanmean([at[s][d] for s in at]) for d in common]
                ax.plot([d / 1e6 for d in common], means,
                        color=colour, lw=2, marker="o", ms=3,
                        label=", ".join(f"{k} {v}" for k, v in zip(keys, point)) or "mean")
                # the band a late change must stay inside to count as stopped moving, at the last mean
                ax.axhspan(means[-1] - PLATEAU_TOLERANCE, means[-1] + PLATEAU_TOLERANCE, color=colour, alpha=0.12,
                           lw=0)
        ax.set_xlabel("decisions (M)")
        ax.set_ylabel(label)
        # the data's own range (not a fixed 0-1), so the +-tolerance band can be seen
        values = np.array([r[metric] for trial in (t for p in points.values() for t in p.values()) for r in trial],
                          dtype=float)
        values = values[np.isfinite(values)]
        if len(values):
            pad = max(0.05 * (values.max() - values.min()), 2 * PLATEAU_TOLERANCE)
            ax.set_ylim(values.min() - pad, values.max() + pad)
    axes[0][0].legend(fontsize=7)
    episodes = int(rows[0].get("episodes", 0))
    fig.suptitle(f"every checkpoint on the same {episodes} selection episodes; thick: mean over seeds, thin: "
                 f"each seed; band: +-{PLATEAU_TOLERANCE:g} around the last mean", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
