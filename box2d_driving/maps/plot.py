"""A picture of a :class:`RoadMap` (matplotlib, from the ``train`` extra)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from box2d_driving.maps.roadmap import RoadMap

MOVEMENT_COLOURS = {"straight": "tab:blue", "left": "tab:orange", "right": "tab:green", "uturn": "tab:red"}
GROUP_COLOURS = ("tab:red", "tab:purple", "tab:brown", "tab:olive")


def plot_map(roadmap: RoadMap, path: str | Path, title: str | None = None) -> Path:
    """Draw drivable area, edges, lanes (arrows), connectors by movement, stop lines, signal heads
    by group and crosswalks; write a PNG to ``path``."""
    try:
        import matplotlib

        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError as exc:  # pragma: no cover
        raise RuntimeError(f"plotting a map needs matplotlib (pip install box2d-driving[train]): {exc}") from None
    fig, ax = plt.subplots(figsize=(7, 7))
    for poly in roadmap.drivable:
        ax.fill(poly[:, 0], poly[:, 1], color="0.85", zorder=0, lw=0)
    if len(roadmap.junction_area):
        area = np.vstack([roadmap.junction_area, roadmap.junction_area[:1]])
        ax.plot(area[:, 0], area[:, 1], color="tab:red", lw=0.8, ls=":", zorder=4, label="junction area")
    for cw in roadmap.crosswalks:
        ax.fill(cw.polygon[:, 0], cw.polygon[:, 1], facecolor="white", edgecolor="0.3", hatch="||", zorder=1, lw=0.5)
    for edge in roadmap.edges:
        ax.plot(edge[:, 0], edge[:, 1], color="k", lw=1.2, zorder=2)
    for lane in roadmap.lanes:
        c = lane.centreline
        ax.plot(c[:, 0], c[:, 1], color="0.55", lw=0.6, ls="--", zorder=2)
        k = len(c) // 2
        ax.annotate("", xy=c[k + 1], xytext=c[k], arrowprops=dict(arrowstyle="->", color="0.3", lw=0.8), zorder=3)
    for conn in roadmap.connectors:
        ax.plot(conn.path[:, 0], conn.path[:, 1], color=MOVEMENT_COLOURS[conn.movement], lw=1.0, alpha=0.8, zorder=3)
    for line in roadmap.stop_lines:
        ax.plot(line.segment[:, 0], line.segment[:, 1], color="k", lw=3, zorder=4)
    for head in roadmap.signals:
        ax.scatter(head.position[0], head.position[1], s=70, marker="s" if not head.inferred else "D",
                   color=GROUP_COLOURS[head.group % len(GROUP_COLOURS)], edgecolor="k", zorder=5)
    for arm in roadmap.arms:
        end = arm.centreline[-1]
        ax.annotate(arm.name or f"arm {arm.id}", end, fontsize=8, ha="center",
                    xytext=(0, 4), textcoords="offset points")
    handles = [plt.Line2D([], [], color=c, label=m) for m, c in MOVEMENT_COLOURS.items()
               if any(x.movement == m for x in roadmap.connectors)]
    handles.append(plt.Line2D([], [], color="tab:red", ls=":", label="junction area"))
    handles += [plt.Line2D([], [], marker="s", ls="", color=GROUP_COLOURS[g], label=f"signal group {g}")
                for g in sorted({h.group for h in roadmap.signals})]
    ax.legend(handles=handles, loc="lower left", fontsize=7, framealpha=0.9)
    ax.set_aspect("equal")
    ax.set_xlabel("east (m)")
    ax.set_ylabel("north (m)")
    src = roadmap.source
    ax.set_title(title or f"{roadmap.name}: {' x '.join(src.get('streets', []))}", fontsize=10)
    attribution = src.get("attribution")
    if attribution:
        ax.text(0.99, 0.01, f"map data {attribution}, {src.get('licence', '')}", transform=ax.transAxes,
                fontsize=6, ha="right", va="bottom", color="0.3")
    x0, y0, x1, y1 = roadmap.bounds()
    pad = 3.0
    ax.set_xlim(x0 - pad, x1 + pad)
    ax.set_ylim(y0 - pad, y1 + pad)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    tmp = path.with_name(path.name + ".partial")  # replaced whole: a failed drawing leaves the old one
    try:
        fig.savefig(tmp, dpi=110, format="png")
        tmp.replace(path)
    finally:
        plt.close(fig)
        tmp.unlink(missing_ok=True)
    return path
