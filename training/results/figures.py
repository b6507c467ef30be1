"""The results page's figures, drawn from grouped sweep results (``training/results/data.py``)."""

from __future__ import annotations

from pathlib import Path
from typing import Callable, Optional

import numpy as np

from training.evaluation import figure_data as fd
from training.results.data import LEARNT_SUCCESS, SINGLE_POINT, Baseline, Group, Metric, as_number

# every figure is drawn as figure(groups, grid keys, PNG path, baseline); only the lights figure
# draws a baseline (the light-blind driver), the others take it to share one signature
Figure = Callable[[list[Group], list[str], Path, Baseline], None]


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def lights_figure(groups: list[Group], keys: list[str], path: Path, blind: Baseline) -> None:
    """Red-light violation rate against cars, one line per LiDAR noise level, with 95 % intervals
    and the per-seed values as dots (the paper's Figure on traffic-light usage, as numbers).
    ``blind``: per noise level, a light-blind driver's 1-car rate on the same episodes (drawn as
    a reference line)."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6.5, 4.2))
    noises = sorted({g.point.get("lidar_noise", "?") for g in groups}, key=as_number)
    cmap = plt.get_cmap("viridis")
    unlearnt = False
    for i, noise in enumerate(noises):
        mine = sorted((g for g in groups if g.point.get("lidar_noise", "?") == noise),
                      key=lambda g: as_number(g.point.get("num_cars")))
        colour = cmap(0.85 * i / max(len(noises) - 1, 1))  # the palest yellow is unreadable on white
        xs = [as_number(g.point.get("num_cars")) + 0.08 * (i - (len(noises) - 1) / 2) for g in mine]
        est = [g.estimates["red_light_violation_rate"] for g in mine]
        lows = [e.mean - e.low if e.low is not None else 0 for e in est]
        highs = [e.high - e.mean if e.high is not None else 0 for e in est]
        ax.errorbar(xs, [e.mean for e in est], yerr=[lows, highs], color=colour, marker="o", capsize=3,
                    ls="none", label=f"LiDAR noise {noise}")
        learnt = [(x, e.mean) for x, e, g in zip(xs, est, mine) if not _unlearnt(g)]
        ax.plot([x for x, _ in learnt], [m for _, m in learnt], color=colour)  # a trend joins learnt points only
        for x, e, g in zip(xs, est, mine):
            ax.scatter([x] * len(e.values), e.values, color=colour, s=10, alpha=0.5)
            if _unlearnt(g):
                unlearnt = True
                ax.scatter([x], [e.mean], s=70, facecolors="white", edgecolors=colour, zorder=3)
    rates = sorted({round(rate, 3) for rate, _ in blind.values()})
    if rates:  # full throttle ignores the sensor: one rate for every noise level (else each is drawn)
        for rate in rates:
            ax.axhline(rate, color="grey", ls=":", lw=1)
        ax.plot([], [], color="grey", ls=":", lw=1,
                label="light-blind driver, 1 car, same episodes (" + " / ".join(f"{r:.3f}" for r in rates) + ")")
    if unlearnt:
        ax.scatter([], [], s=70, facecolors="white", edgecolors="black",
                   label=f"hollow: mean success < {LEARNT_SUCCESS} (not learnt at this budget; not joined)")
    ax.set_xticks(sorted({as_number(g.point.get("num_cars")) for g in groups}))
    ax.set_xlabel("cars per episode")
    ax.set_ylabel("red-light violation rate")
    ax.set_ylim(0, 1)
    ax.set_title("Red-light violations (mean, 95 % interval over training seeds)", fontsize=10)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def _unlearnt(g: Group) -> bool:
    """Whether a grid point's policies have not learnt the task (mean success below the bar)."""
    success = g.estimates.get("success_rate")
    return success is not None and bool(success.n) and success.mean < LEARNT_SUCCESS


def bars_figure(metric: Metric, label: str, dots: Optional[tuple[Metric, str]] = None) -> Figure:
    """One bar per grid point with its 95 % interval and per-seed dots; ``dots``: another metric
    (and its legend label) whose per-seed values are drawn as the dots instead, e.g. the signed
    values behind a bar of sizes, so that each seed's sign shows."""
    def draw(groups: list[Group], keys: list[str], path: Path, baseline: Baseline) -> None:
        plt = _plt()
        fig, ax = plt.subplots(figsize=(max(4.0 if dots is None else 5.5, 1.2 * len(groups) + 2), 3.8))
        for i, g in enumerate(groups):
            e = g.estimates[metric]
            err = [[e.mean - e.low], [e.high - e.mean]] if e.low is not None and e.high is not None else None
            ax.bar(i, e.mean, yerr=err, capsize=4, color="tab:blue", alpha=0.7)
            values = g.estimates[dots[0]].values if dots is not None else e.values
            ax.scatter([i] * len(values), values, color="black", s=12, zorder=3)
        # scripted drivers on the same report episodes (a baseline keyed DRIVER/METRIC), as lines
        for (key, (value, _)), style in zip(sorted((k, v) for k, v in baseline.items()
                                                    if isinstance(k, str) and k.endswith(f"/{metric}")),
                                             ("--", ":", "-.")):
            ax.axhline(value, color="tab:red", ls=style, lw=1.2, label=key.split("/", 1)[0])
        if any(isinstance(k, str) and k.endswith(f"/{metric}") for k in baseline):
            ax.legend(fontsize=7, title="scripted drivers", title_fontsize=7)
        if dots is not None:
            ax.axhline(0.0, color="grey", lw=0.8, zorder=1)
            ax.set_title(f"bar: mean, 95 % interval over seeds\ndots: {dots[1]}", fontsize=8)
        ax.set_xticks(range(len(groups)), [_label(g, keys) for g in groups], fontsize=8, rotation=20)
        ax.set_ylabel(label)
        fig.tight_layout()
        fig.savefig(path, dpi=110)
        plt.close(fig)
    return draw


# the point key of a bar that is not one of the section's grid points (the row it is compared with)
COMPARED = "compared with"


def _label(g: Group, keys: list[str]) -> str:
    if COMPARED in g.point:
        return g.point[COMPARED]
    return ", ".join(f"{k}={g.point[k]}" for k in keys) or SINGLE_POINT


def distribution_figure(name: str, bins: np.ndarray, xlabel: str, fallback: Figure,
                        mark: Optional[tuple[float, str]] = None, clipped: str = "") -> Figure:
    """One normalised histogram per grid point (counts summed over its seeds); ``fallback`` draws
    when no trial stored the distribution. ``clipped`` (the unit, e.g. ``"m"``): the last bin also
    holds every sample beyond the range (the trials store them clipped there); it is labelled so."""
    def draw(groups: list[Group], keys: list[str], path: Path, baseline: Baseline) -> None:
        if not any(name in g.figures for g in groups):
            return fallback(groups, keys, path, baseline)
        plt = _plt()
        fig, ax = plt.subplots(figsize=(6.5, 4.0))
        centres = (bins[:-1] + bins[1:]) / 2
        for g in groups:
            if name in g.figures and g.figures[name].sum() > 0:
                share = g.figures[name] / g.figures[name].sum()
                seeds = f"{len(g.seeds)} seed{'' if len(g.seeds) == 1 else 's'}"
                ax.step(centres, share, where="mid", label=f"{_label(g, keys)} ({seeds})")
        if mark is not None:
            ax.axvline(mark[0], color="grey", ls=":", lw=1, label=mark[1])
        if clipped:
            ax.axvspan(bins[-2], bins[-1], color="grey", alpha=0.15,
                       label=f"last bin: every sample at {bins[-2]:g} {clipped} or more")
        ax.set_xlabel(xlabel)
        ax.set_ylabel("share of samples")
        ax.legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(path, dpi=110)
        plt.close(fig)
    return draw


def gap_figure(fallback: Figure, a_max: float = 1.5) -> Figure:
    """Gap to the car ahead against closing speed (counts over seeds, log colour), with the
    speed-matching boundary ``gap = v^2 / (2 a_max)``: samples above it can still stop."""
    def draw(groups: list[Group], keys: list[str], path: Path, baseline: Baseline) -> None:
        have = [g for g in groups if "gap_closing_counts" in g.figures]
        if not have:
            return fallback(groups, keys, path, baseline)
        plt = _plt()
        fig, axes = plt.subplots(1, len(have), figsize=(4.8 * len(have), 4.0), squeeze=False)
        v = np.linspace(0, fd.CLOSING_BINS[-1], 50)
        for ax, g in zip(axes[0], have):
            counts = np.asarray(g.figures["gap_closing_counts"], dtype=float)
            mesh = ax.pcolormesh(fd.CLOSING_BINS, fd.GAP_BINS, np.log1p(counts), cmap="Blues")
            fig.colorbar(mesh, ax=ax, label="ln(1 + samples), over seeds")
            ax.plot(v, v ** 2 / (2 * a_max), color="tab:red", label="speed-matching distance")
            ax.set_ylim(fd.GAP_BINS[0], fd.GAP_BINS[-1])
            ax.set_xlabel("closing speed (m/s)")
            ax.set_ylabel("gap to the car ahead (m)")
            ax.set_title(_label(g, keys), fontsize=9)
            ax.legend(fontsize=8)
        fig.tight_layout()
        fig.savefig(path, dpi=110)
        plt.close(fig)
    return draw


def against_noise_figure(panels: tuple[tuple[Metric, str], ...]) -> Figure:
    """One panel per (metric, label): the metric against LiDAR noise, mean with its 95 % interval
    over training seeds and the per-seed values as dots (the paper's communication figure)."""
    def draw(groups: list[Group], keys: list[str], path: Path, baseline: Baseline) -> None:
        plt = _plt()
        fig, axes = plt.subplots(1, len(panels), figsize=(4.6 * len(panels), 3.8), squeeze=False)
        mine = sorted(groups, key=lambda g: as_number(g.point.get("lidar_noise")))
        xs = [as_number(g.point.get("lidar_noise")) for g in mine]
        for ax, (metric, label) in zip(axes[0], panels):
            est = [g.estimates[metric] for g in mine]
            lows = [e.mean - e.low if e.low is not None else 0 for e in est]
            highs = [e.high - e.mean if e.high is not None else 0 for e in est]
            ax.errorbar(xs, [e.mean for e in est], yerr=[lows, highs], marker="o", capsize=3, color="tab:blue")
            for x, e in zip(xs, est):
                ax.scatter([x] * len(e.values), e.values, color="black", s=10, alpha=0.6, zorder=3)
            ax.axhline(0.0, color="grey", lw=0.8, zorder=1)  # where "above zero" is the question, zero is drawn
            # scripted drivers on the same report episodes (a baseline keyed DRIVER/METRIC), as lines
            drawn = sorted((k.split("/", 1)[0], v) for k, (v, _) in baseline.items()
                           if k.split("/", 1)[1] == str(metric) and np.isfinite(v))
            for (driver, value), style in zip(drawn, ("--", ":", "-.")):
                ax.axhline(value, color="tab:red", ls=style, lw=1.2, label=driver)
            if drawn:
                ax.legend(fontsize=7, title="scripted drivers", title_fontsize=7)
            ax.set_xlabel("LiDAR noise (share of rays dropped)")
            ax.set_ylabel(label)
            ax.set_xticks(xs)
        fig.suptitle("mean, 95 % interval over training seeds; dots: seeds", fontsize=9)
        fig.tight_layout()
        fig.savefig(path, dpi=110)
        plt.close(fig)
    return draw
