"""Plots for evaluation reports (matplotlib, headless)."""

from __future__ import annotations

import csv
from pathlib import Path
from typing import Optional

import numpy as np


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    return plt


def read_progress(run_dir: Path) -> Optional[dict[str, np.ndarray]]:
    """Training curves from ``progress.csv`` (and the ``progress.resumed_*.csv`` of each
    ``--resume``, in order) of a run folder."""
    rows = []
    for path in [run_dir / "progress.csv"] + sorted(run_dir.glob("progress.resumed_*.csv")):
        if path.exists():
            with open(path) as f:
                rows += list(csv.DictReader(f))
    if not rows:
        return None
    keys = ["time/agent_steps", "time/total_timesteps", "time/wall_s", "rollout/success_rate",
            "rollout/collision_rate", "rollout/red_light_violation_rate",
            "rollout/lidar_input_spread", "rollout/lidar_feature_spread"]  # runs before these log nan
    out = {}
    for k in keys:
        out[k] = np.array([float(r[k]) if r.get(k) not in (None, "") else np.nan for r in rows])
    return out


CURVES = (("rollout/success_rate", "success", "tab:blue"),
          ("rollout/collision_rate", "collision", "tab:orange"),
          ("rollout/red_light_violation_rate", "red-light violation", "tab:green"))


def learning_curves(progress: dict[str, np.ndarray], path: Path,
                    mark_agent_steps: Optional[float] = None) -> None:
    """Rates over agent-steps and over wall-clock hours; ``mark_agent_steps`` draws a line where
    the evaluated checkpoint was taken."""
    plt = _plt()
    fig, ax = plt.subplots(1, 2, figsize=(11, 4))
    for axis, x, xlabel in ((ax[0], progress["time/agent_steps"] / 1e6, "agent-steps (millions)"),
                            (ax[1], progress["time/wall_s"] / 3600, "wall-clock hours")):
        for key, label, colour in CURVES:
            if np.isfinite(progress[key]).any():
                axis.plot(x, progress[key], label=label, color=colour)
        axis.set_xlabel(xlabel)
        axis.set_ylim(0, 1)
    if mark_agent_steps is not None:
        ax[0].axvline(mark_agent_steps / 1e6, color="black", lw=1, ls="--", label="this checkpoint")
    ax[0].set_ylabel("rate (stochastic training rollouts)")
    ax[0].legend(fontsize=8)
    ax[0].set_title("training curves")
    ax[1].set_title("against training time")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


LIGHT_VALUE_COLOURS = {0.0: "tab:blue", 0.5: "tab:orange", 1.0: "tab:purple"}  # fixed per value


def acceleration_by_light(table: dict[str, np.ndarray], path: Path, stop_value: float = 1.0,
                          bins=(0, 10, 20, 30, 50)) -> None:
    """Box plots of the acceleration chosen against distance to the stop line, per light seen.
    Each light value keeps its colour in every run (neutral ones: a policy may adopt either
    extreme as "stop"); the legend says which value this policy stops on."""
    plt = _plt()
    # the action at decision t responds to the observation at t-1: pair them per car
    order = np.lexsort((table["decision"], table["car"], table["episode"]))
    ep, car = table["episode"][order], table["car"][order]
    same = (ep[1:] == ep[:-1]) & (car[1:] == car[:-1])
    light = table["light"][order][:-1][same]
    dist = table["stop_line_distance"][order][:-1][same]
    accel = table["acceleration"][order][1:][same]
    fig, ax = plt.subplots(figsize=(9, 4))
    values = [v for v in (0.0, 0.5, 1.0) if np.any(np.isclose(light, v))]
    # only the distance bins some car was in (a world whose cars start near the line has no far bin)
    lit = np.any([np.isclose(light, v) for v in values], axis=0) if values else np.zeros(len(light), bool)
    spans = [(lo, hi) for lo, hi in zip(bins[:-1], bins[1:]) if np.any(lit & (dist > lo) & (dist <= hi))]
    width = 0.8 / max(len(values), 1)
    go_value = 1.0 - stop_value
    colours = LIGHT_VALUE_COLOURS
    names = {stop_value: f"{stop_value} (stop)", go_value: f"{go_value} (go)", 0.5: "0.5"}
    for j, v in enumerate(values):
        data, pos = [], []
        for b, (lo, hi) in enumerate(spans):
            m = np.isclose(light, v) & (dist > lo) & (dist <= hi)
            data.append(accel[m] if m.any() else np.array([np.nan]))
            pos.append(b + (j - (len(values) - 1) / 2) * width)
        # outlines and whiskers in the series' colour: a box with no spread is a line, and stays
        # readable as this light's only where it is not black
        line = {"color": colours[v], "linewidth": 1.5}
        bp = ax.boxplot(data, positions=pos, widths=width * 0.9, patch_artist=True, showfliers=False,
                        medianprops={"color": "black"}, whiskerprops=line, capprops=line,
                        boxprops={"edgecolor": colours[v], "linewidth": 1.5})
        for patch in bp["boxes"]:
            patch.set_facecolor(colours[v])
            patch.set_alpha(0.6)
        medians = [float(np.median(d)) if np.isfinite(d).any() else np.nan for d in data]
        ax.scatter(pos, medians, color=colours[v], edgecolor="black", s=18, zorder=3)
        ax.plot([], [], color=colours[v], lw=6, alpha=0.6, label=f"light {names[v]}")
    ax.set_xticks(range(len(spans)))
    ax.set_xticklabels([f"{lo}-{hi} m" for lo, hi in spans])
    ax.set_xlabel("distance to the stop line")
    ax.set_ylabel("acceleration (m/s²)")
    ax.legend(fontsize=8)
    ax.set_title("acceleration by light seen and distance to the junction")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def junction_light_histogram(table: dict[str, np.ndarray], entries: dict[str, np.ndarray],
                             go_value: float, path: Path, bins: int = 24) -> None:
    """Inside the junction: share of car positions whose entry light was the 'go' value."""
    plt = _plt()
    key = {(e, c): light for e, c, light in zip(entries["episode"], entries["car"], entries["light"])}
    inside = np.flatnonzero(table["in_junction"])
    points, went = [], []
    for i in inside:
        k = (table["episode"][i], table["car"][i])
        if k in key:
            points.append((table["x"][i], table["y"][i]))
            went.append(np.isclose(key[k], go_value))
    fig, ax = plt.subplots(figsize=(5, 4.5))
    if points:
        pts = np.array(points)
        go = np.array(went, dtype=float)
        lim = np.abs(pts).max()
        edges = np.linspace(-lim, lim, bins + 1)
        total, _, _ = np.histogram2d(pts[:, 0], pts[:, 1], bins=[edges, edges])
        good, _, _ = np.histogram2d(pts[:, 0], pts[:, 1], bins=[edges, edges], weights=go)
        share = np.where(total > 0, good / np.maximum(total, 1), np.nan)
        im = ax.imshow(share.T, origin="lower", extent=[-lim, lim, -lim, lim], cmap="RdYlGn",
                       vmin=0, vmax=1)
        fig.colorbar(im, ax=ax, label=f"share entered on 'go' ({go_value})")
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")
    ax.set_title("light seen before entering, by position")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def pedestrian_distance_kde(distances: np.ndarray, path: Path, control: Optional[np.ndarray] = None) -> None:
    """Kernel density of the distance to the nearest pedestrian ahead, with the mean and the
    central 95 % band (and the invisible-pedestrian control, if given)."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(7, 4))
    for d, label, colour in ((distances, "policy", "tab:blue"), (control, "pedestrians invisible", "tab:red")):
        if d is None or len(d) < 2:
            continue
        grid = np.linspace(0, max(60.0, float(np.max(d))), 400)
        bw = 1.06 * max(np.std(d), 1e-3) * len(d) ** (-1 / 5)
        dens = np.exp(-0.5 * ((grid[:, None] - d[None, :]) / bw) ** 2).sum(1) / (len(d) * bw * np.sqrt(2 * np.pi))
        ax.plot(grid, dens, color=colour, label=f"{label} (n={len(d)})")
        lo, hi = np.percentile(d, [2.5, 97.5])
        ax.axvspan(lo, hi, color=colour, alpha=0.08)
        ax.axvline(np.mean(d), color=colour, ls="--", lw=1)
    ax.axvline(6.0, color="grey", ls=":", lw=1, label="6 m")
    ax.set_xlabel("distance to the nearest pedestrian ahead (m)")
    ax.set_ylabel("density")
    ax.legend(fontsize=8)
    ax.set_title("pedestrian distance (dashed: mean, band: central 95 %)")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def speed_vs_distance(distance: np.ndarray, speed: np.ndarray, a_max: float, path: Path,
                      xlabel: str = "distance to the nearest pedestrian ahead (m)",
                      ylabel: str = "speed (m/s)", marked: np.ndarray | None = None,
                      marked_label: str = "") -> None:
    """Scatter of speed against distance with the safe-stopping region ``d >= v^2/(2 a_max)``;
    samples where ``marked`` is true are drawn in red under ``marked_label``."""
    distance, speed = np.asarray(distance), np.asarray(speed)
    marked = np.zeros(len(distance), dtype=bool) if marked is None else np.asarray(marked, dtype=bool)
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6, 4.5))
    v_max = max(float(np.max(speed)) if len(speed) else 1.0, 1.0) * 1.05
    v = np.linspace(0, v_max, 200)
    d_max = max(float(np.max(distance)) if len(distance) else 10.0, v_max**2 / (2 * a_max)) * 1.05
    ax.fill_betweenx(v, v**2 / (2 * a_max), d_max, color="tab:green", alpha=0.15, label="safe: d >= v²/2a")
    ax.scatter(distance[~marked], speed[~marked], s=4, alpha=0.4)
    if marked.any():
        ax.scatter(distance[marked], speed[marked], s=6, alpha=0.7, color="tab:red", label=marked_label)
    ax.set_xlim(0, d_max)
    ax.set_ylim(0, v_max)
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    ax.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def collision_kinds(breakdown: dict, path: Path, cars: int) -> None:
    """Bars of collided cars per kind (share of all cars), split into inside / outside the junction
    (``breakdown`` from :func:`box2d_driving.metrics.collisions.collision_breakdown`)."""
    plt = _plt()
    names = list(breakdown["by_kind"])
    inside = np.array([breakdown["by_kind"][k]["in_junction"] for k in names]) / max(cars, 1)
    total = np.array([breakdown["by_kind"][k]["cars"] for k in names]) / max(cars, 1)
    fig, ax = plt.subplots(figsize=(6, 3.5))
    y = np.arange(len(names))
    ax.barh(y, inside, color="tab:red", label="in the junction")
    ax.barh(y, total - inside, left=inside, color="tab:orange", label="outside")
    ax.set_yticks(y, [k.replace("_", " ") for k in names])
    ax.set_xlim(0, max(float(total.max(initial=0.0)), 0.01) * 1.1)
    ax.invert_yaxis()
    ax.set_xlabel("collided cars per car driven")
    ax.set_title(f"what the {breakdown['collided_cars']} collided cars hit ({cars} cars)")
    ax.legend(fontsize=8, loc="lower right")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def lane_histogram(samples: dict[str, np.ndarray], path: Path, bins: int = 24) -> None:
    """Histograms of normalised lane position through the junction (+ = right of the direction
    of travel), one per labelled sample set (e.g. per run or noise level)."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(7, 4))
    edges = np.linspace(-1, 1, bins + 1)
    for label, s in samples.items():
        if len(s):
            ax.hist(np.clip(s, -1, 1), bins=edges, density=True, histtype="step", lw=2, label=f"{label} (n={len(s)})")
    ax.axvline(0, color="grey", lw=1, ls=":")
    ax.set_xlabel("normalised lane position in the junction (-1 left edge, +1 right edge)")
    ax.set_ylabel("density")
    ax.legend(fontsize=8)
    ax.set_title("where cars cross the junction")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def lateral_over_time(table: dict[str, np.ndarray], road_width: float, path: Path,
                      episodes: int = 3) -> None:
    """Lateral position ``2y/W`` of every car over the first ``episodes`` episodes, coloured by
    acceleration rating (the paper's fast-lane figure), next to rating vs final position."""
    plt = _plt()
    from box2d_driving.metrics.lanes import final_lateral_positions

    fig, ax = plt.subplots(1, 2, figsize=(12, 4.5), gridspec_kw={"width_ratios": [2, 1]})
    cmap = plt.get_cmap("viridis")
    lo, hi = float(np.min(table["rating"])), float(np.max(table["rating"]))
    norm = plt.Normalize(lo, hi if hi > lo else lo + 1e-6)
    offset = 0
    for ep in np.unique(table["episode"])[:episodes]:
        rows = table["episode"] == ep
        for car in np.unique(table["car"][rows]):
            r = rows & (table["car"] == car)
            order = np.argsort(table["decision"][r])
            t = table["decision"][r][order] + offset
            ax[0].plot(t, 2 * table["y"][r][order] / road_width, color=cmap(norm(table["rating"][r][0])), lw=1.2)
        offset += int(table["decision"][rows].max()) + 3
    ax[0].set_xlabel("decision (episodes side by side)")
    ax[0].set_ylabel("lateral position 2y/W (+ = left)")
    ax[0].set_ylim(-1, 1)
    rating, lateral = final_lateral_positions(table, road_width)
    ax[1].scatter(rating, lateral, c=rating, cmap=cmap, norm=norm, s=10)
    ax[1].set_xlabel("acceleration rating")
    ax[1].set_ylabel("final lateral position 2y/W")
    ax[1].set_ylim(-1, 1)
    fig.colorbar(plt.cm.ScalarMappable(norm=norm, cmap=cmap), ax=ax[1], label="rating")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def metric_over_training(steps: np.ndarray, values: dict[str, np.ndarray], path: Path, ylabel: str,
                         reference: Optional[tuple[float, str]] = None) -> None:
    """Evaluation metrics of a run's checkpoints against agent-steps (one line per metric)."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(6, 4))
    for label, v in values.items():
        ax.plot(steps, v, marker="o", ms=3, label=label)
    if reference is not None:
        ax.axhline(reference[0], color="0.4", ls="--", lw=1, label=reference[1])
    ax.set_xlabel("agent-steps")
    ax.set_ylabel(ylabel)
    ax.set_ylim(0, 1.02)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
