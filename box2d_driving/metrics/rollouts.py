"""Recording rollouts: one row per car per decision, from the env's ``infos``.

A rollout table is a dict of equal-length NumPy columns (see :data:`COLUMNS`), saved as ``.npz``.
Row ``decision == 0`` is the state at reset (no action taken yet); a car's rows end on the
decision its trajectory ends.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import TYPE_CHECKING, Any, Callable, Optional

import numpy as np

if TYPE_CHECKING:  # for the annotations only: nothing of the policies is imported at run time
    from box2d_driving.policies.protocol import Policy

COLUMNS = ("episode", "car", "decision", "x", "y", "heading", "speed", "acceleration", "light",
           "in_junction", "lane_offset", "distance_to_goal", "arrived", "collided", "reward",
           "approach", "rating", "stop_line_distance")
# Scenario-specific numeric facts recorded when present (NaN otherwise).
OPTIONAL_COLUMNS = ("pedestrian_distance", "crosswalk_distance", "bit_sent")
COLLIDED_WITH = ("", "car", "edge", "pedestrian")
# Who a collided car hit: the other car's index (-1: none, or not a car) and whether that car had
# already halted (a wreck). Tables recorded before these existed lack them.
COLLISION_COLUMNS = ("collision_partner", "partner_halted")


class RolloutRecorder:
    """Collects rows from ``reset``/``step`` infos; :meth:`table` returns the columns.

    Args:
        extra_columns: more numeric info keys to record as float columns (NaN where a car's info
            lacks one or holds None): a scenario's own facts (:func:`scenario_columns`).
    """

    def __init__(self, extra_columns: tuple[str, ...] = ()) -> None:
        self.extra_columns = tuple(c for c in extra_columns if c not in COLUMNS + OPTIONAL_COLUMNS)
        self.rows: list[tuple] = []
        self.collided_with: list[int] = []
        self.partners: list[tuple[int, bool]] = []

    def add(self, episode: int, infos: dict[str, dict[str, Any]],
            rewards: Optional[dict[str, float]] = None) -> None:
        for agent, info in infos.items():
            car = int(agent.rsplit("_", 1)[1])
            x, y = info["position"]
            self.rows.append((
                episode, car, info["decision"], x, y, info["heading"], info["speed"],
                info["acceleration"], info["light"], info["in_junction"], _num(info["lane_offset"]),
                info["distance_to_goal"], info["arrived"], info["collided"],
                0.0 if rewards is None else rewards[agent], info.get("approach", -1),
                info.get("rating", 1.0), _num(info.get("stop_line_distance")),
                *(_num(info.get(k)) for k in OPTIONAL_COLUMNS + self.extra_columns),
            ))
            self.collided_with.append(COLLIDED_WITH.index(info["collided_with"] or ""))
            self.partners.append((info.get("collision_partner", -1), info.get("partner_halted", False)))

    def table(self) -> dict[str, np.ndarray]:
        floats = OPTIONAL_COLUMNS + self.extra_columns
        names = COLUMNS + floats
        cols: list = list(zip(*self.rows)) if self.rows else [[] for _ in names]
        out = {name: np.asarray(col, dtype=float if name in floats else None)
               for name, col in zip(names, cols)}
        for name in ("episode", "car", "decision", "approach"):
            out[name] = out[name].astype(np.int64)
        for name in ("in_junction", "arrived", "collided"):
            out[name] = out[name].astype(bool)
        out["collided_with"] = np.asarray(self.collided_with, dtype=np.int64)
        partner, halted = (list(c) for c in zip(*self.partners)) if self.partners else ([], [])
        out["collision_partner"] = np.asarray(partner, dtype=np.int64)
        out["partner_halted"] = np.asarray(halted, dtype=bool)
        return out


def last_rows(table: dict[str, np.ndarray]) -> np.ndarray:
    """Index of each car's last row (its final decision) in every episode."""
    order = np.lexsort((table["decision"], table["car"], table["episode"]))
    ep, car = table["episode"][order], table["car"][order]
    is_last = np.ones(len(order), dtype=bool)
    is_last[:-1] = (ep[1:] != ep[:-1]) | (car[1:] != car[:-1])
    return order[is_last]


def row_lookup(table: dict[str, np.ndarray]) -> Callable[[Any, Any, Any], np.ndarray]:
    """A function ``find(episode, car, decision)`` (scalars or equal-length arrays) giving the
    table row of each (episode, car, decision), -1 where the table has none."""
    ep, car, dec = (table[k].astype(np.int64) for k in ("episode", "car", "decision"))
    span_car, span_dec = int(car.max(initial=0)) + 1, int(dec.max(initial=0)) + 1
    key = (ep * span_car + car) * span_dec + dec  # one int64 per row, sorted once
    order = np.argsort(key, kind="stable")
    sorted_key = key[order]

    def find(episode: Any, car_: Any, decision: Any) -> np.ndarray:
        e, c, d = (np.asarray(v, dtype=np.int64) for v in (episode, car_, decision))
        want = (e * span_car + c) * span_dec + d
        if not len(order):
            return np.full(want.shape, -1, dtype=np.int64)
        i = np.minimum(np.searchsorted(sorted_key, want), len(order) - 1)
        # a car or decision out of range would alias another row's key
        hit = (c >= 0) & (c < span_car) & (d >= 0) & (d < span_dec) & (sorted_key[i] == want)
        return np.where(hit, order[i], -1)
    return find


def _num(value: Optional[float]) -> float:
    return float("nan") if value is None else float(value)


def save_table(table: dict[str, np.ndarray], path: Path) -> None:
    """A rollout table as a compressed ``.npz`` (plain arrays only; ``.npz`` added to a ``path``
    without it, as numpy does), written whole or not at all: into a partial file, then renamed."""
    path = Path(path)
    if path.suffix != ".npz":
        path = path.with_name(path.name + ".npz")
    partial = path.with_name(path.name + ".partial.npz")
    np.savez_compressed(partial, **table)  # type: ignore[arg-type]  # numpy's stub types the keywords as its flags
    os.replace(partial, path)


def load_table(path: Path) -> dict[str, np.ndarray]:
    """A rollout table saved by :func:`save_table`."""
    with np.load(path, allow_pickle=False) as data:  # a rollout file never unpickles
        return {k: data[k] for k in data.files}


def scenario_columns(env: Any) -> tuple[str, ...]:
    """The numeric facts a scenario adds to its cars' infos (its env's ``scenario_info_fields``),
    recorded as columns of its rollout tables."""
    return tuple(getattr(getattr(env, "unwrapped", env), "scenario_info_fields", {}))


def run_episodes(env: Any, policy: Policy, episodes: int, seed: int = 0,
                 recorder: Optional[RolloutRecorder] = None) -> dict[str, np.ndarray]:
    """Run ``episodes`` episodes with ``policy.act`` and return the rollout table (with the env's
    own columns, :func:`scenario_columns`)."""
    recorder = recorder or RolloutRecorder(scenario_columns(env))
    for ep in range(episodes):
        obs, infos = env.reset(seed=seed + ep)
        recorder.add(ep, infos)
        while env.agents:
            obs, rewards, _, _, infos = env.step(policy.act({a: obs[a] for a in env.agents}))
            recorder.add(ep, infos, rewards)
    return recorder.table()
