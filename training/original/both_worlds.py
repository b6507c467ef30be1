"""``box2d-driving original both-worlds``: trained policies driven in both worlds, taken together.

Each policy (an original run's actor, or a policy of ours trained in the ``paper`` preset) drives
the same block of report episodes in sdriving's world and in ours; one table per policy and world
is kept in the ``--out`` folder (a later call reads the tables already there, so a stopped run
continues). The report gives each policy's rates in both worlds and, for all policies together,
the rates in each world and their difference, original minus ours, with 95 % intervals.

Why together, and with episodes as clusters: every policy drives the *same* episodes of a world,
while the two worlds' episodes are independent draws (their random streams differ). A difference
taken per policy and then averaged over policies with an interval over policies alone would treat
the two blocks' luck, which every policy shares, as if it were a property of the worlds: a block
of episodes that happens to be easier in one world makes every policy look better there. Pooling
the policies' tables with each episode one cluster (:func:`box2d_driving.metrics.intervals.pooled_rate_intervals`)
counts that luck, and the difference's half-width adds the two worlds' in quadrature (independent
blocks).
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Optional, Sequence

import numpy as np

from training.original.commands import OriginalError
from training.original.tables import policy_source, run_weights, write_table

WORLDS = ("original", "ours")
RATE_NAMES = ("red_light_violation_rate", "success_rate", "collision_rate")
REPORT_FILE = "report.json"


@dataclass(frozen=True)
class Driver:
    """A trained policy to drive both worlds: ``name`` (its tables' file stem), and either an
    original run folder with its last actor (``run``, ``weights``) or a policy of ours
    (``policy``, with ``original``, it as the original's actor)."""

    name: str
    run: Optional[Path] = None
    weights: Optional[Path] = None
    policy: Optional[Path] = None
    original: Optional[tuple[dict, dict]] = None


def drivers(runs: Sequence[Path], policies: Sequence[Path]) -> list[Driver]:
    """The drivers of ``runs`` (original run folders, each at its last epoch) and ``policies``
    (ours), checked before anything runs; named by their folders, which must differ."""
    found = [Driver(run.name, run=run, weights=run_weights(run, None)) for run in runs]
    found += [Driver(policy.name, policy=policy, original=policy_source(policy)) for policy in policies]
    if not found:
        raise OriginalError("give the policies to drive: --run RUN ... and/or --policy POLICY ...")
    names = [d.name for d in found]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:
        raise OriginalError(f"two drivers named {twice[0]!r}: their tables would share a file; give folders "
                            "with different names")
    return found


def table_path(out: Path, driver: Driver, world: str) -> Path:
    return out / f"{driver.name}_{world}.npz"


def drive(out: Path, found: Sequence[Driver], episodes: int, first_seed: int, overrides: dict) -> None:
    """Write every driver's table in each world that ``out`` does not hold yet (each whole or not
    at all: written under another name, then renamed), printing each as it starts."""
    for driver in found:
        for world in WORLDS:
            path = table_path(out, driver, world)
            if path.exists():
                continue
            print(f"{driver.name}: {episodes} episodes in the {world} world", flush=True)
            partial = path.with_name(path.stem + ".partial.npz")
            write_table(partial, world, episodes, first_seed, run=driver.run, weights=driver.weights,
                        policy=driver.policy, original=driver.original,
                        overrides=overrides if world == "ours" else None)
            os.replace(partial, path)


def report(out: Path, found: Sequence[Driver]) -> dict:
    """Each driver's rates in both worlds, all drivers' pooled rates per world and their
    difference (original minus ours) with its 95 % half-width and whether it is within it."""
    from box2d_driving.metrics.intervals import pooled_rate_intervals, rate_intervals
    from box2d_driving.metrics.rollouts import load_table

    tables = {world: [load_table(table_path(out, d, world)) for d in found] for world in WORLDS}
    per_driver = {d.name: {world: rate_intervals(tables[world][k], RATE_NAMES) for world in WORLDS}
                  for k, d in enumerate(found)}
    pooled = {world: pooled_rate_intervals(tables[world], RATE_NAMES) for world in WORLDS}
    difference = {}
    for name in RATE_NAMES:
        if name in pooled["original"] and name in pooled["ours"]:
            a, b = pooled["original"][name], pooled["ours"][name]
            half = float(np.hypot(a["half_width"], b["half_width"]))
            value = a["value"] - b["value"]
            difference[name] = {"value": value, "half_width": half, "within": bool(abs(value) <= half)}
    return {"drivers": per_driver, "pooled": pooled, "original_minus_ours": difference}


def markdown(result: dict) -> str:
    """The report as a table: a row per driver and world, the pooled rows, the difference."""
    def cell(entry: Optional[dict]) -> str:
        return "-" if entry is None else f"{entry['value']:.3f} ± {entry['half_width']:.3f}"

    lines = ["| driver | world | " + " | ".join(RATE_NAMES) + " |", "|---|---|" + "---|" * len(RATE_NAMES)]
    for name, worlds in result["drivers"].items():
        for world in WORLDS:
            lines.append(f"| {name} | {world} | " + " | ".join(cell(worlds[world].get(r)) for r in RATE_NAMES) + " |")
    for world in WORLDS:
        lines.append(f"| all, pooled | {world} | "
                     + " | ".join(cell(result["pooled"][world].get(r)) for r in RATE_NAMES) + " |")
    diff = result["original_minus_ours"]
    lines.append("| all | original minus ours | " + " | ".join(
        cell(diff.get(r)) + ("" if r not in diff or diff[r]["within"] else " (outside)") for r in RATE_NAMES) + " |")
    return "\n".join(lines)


def write_report(out: Path, result: dict) -> Path:
    path = out / REPORT_FILE
    partial = path.with_name(path.name + ".partial")
    partial.write_text(json.dumps(result, indent=1, default=float) + "\n")
    os.replace(partial, path)
    return path
