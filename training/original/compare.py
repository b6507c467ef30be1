"""The same scripted drivers in the paper's simulator and in ours, scored by one piece of code.

``box2d-driving original compare`` records ``--episodes`` report episodes per driver in each world
(the original through ``sdriving_worker.py rollout``, ours through :func:`ours_table`: our
rollout table with the noise-free LiDAR and the sat-nav readings added), then
prints :func:`box2d_driving.metrics.world_compare.world_statistics` of both side by side with
whether each pair agrees within its 95 % interval. The tables are kept (``--out``) so the
numbers can be read again without rerunning either world.
"""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path
from typing import Any, Optional, Sequence

import numpy as np

from box2d_driving.metrics.rollouts import RolloutRecorder, load_table, save_table
from box2d_driving.metrics.world_compare import agree, world_statistics
from box2d_driving.policies.scripted import CONSTANT_SPEED_FRACTION, make_policy
from box2d_driving.registry import make
from training.original.commands import OriginalError, OriginalRun
from training.original.out_folder import check_settings

DRIVERS = ("full-throttle", "constant-speed", "rule", "random")


class _ObservationRecorder(RolloutRecorder):
    """A :class:`RolloutRecorder` that also keeps what each row's car observes: its noise-free
    LiDAR (rays with a return and the nearest return, m; inverse encoding, so it must be recorded
    with ``lidar_noise=0``) and its sat-nav's heading error (rad) and ``1 / max(distance, 1)``,
    all read from the newest frame of the observation."""

    def __init__(self, env: Any) -> None:
        super().__init__()
        self.env = env
        self.returns: list[int] = []
        self.nearest: list[float] = []
        self.heading_read: list[float] = []
        self.goal_read: list[float] = []
        self.observations: dict[str, np.ndarray] = {}

    def add(self, episode, infos, rewards=None) -> None:
        super().add(episode, infos, rewards)
        layout = self.env.observation_layout
        for agent in infos:
            obs = self.observations[agent]
            newest = obs[layout.lidar][-layout.n_rays:]
            hits = newest[newest > 0]
            self.returns.append(int(len(hits)))
            self.nearest.append(float(1.0 / hits.max()) if len(hits) else float("inf"))
            satnav = obs[layout.satnav].reshape(layout.history, -1)[-1]  # light, speed, heading, goal
            self.heading_read.append(float(satnav[2]))
            self.goal_read.append(float(satnav[3]))

    def table(self) -> dict[str, np.ndarray]:
        out = super().table()
        out["lidar_returns"] = np.asarray(self.returns, dtype=np.int64)
        out["lidar_nearest"] = np.asarray(self.nearest, dtype=float)
        out["satnav_heading"] = np.asarray(self.heading_read, dtype=float)
        out["satnav_goal"] = np.asarray(self.goal_read, dtype=float)
        return out


def ours_table(driver: str, episodes: int, first_seed: int, overrides: dict[str, Any],
               preset: Optional[str] = None) -> dict[str, np.ndarray]:
    """``episodes`` episodes of our intersection (the ``preset``'s values and ``overrides`` on its
    config, LiDAR noise 0) driven by the scripted ``driver``, episode ``k`` reset with seed
    ``first_seed + k``."""
    env = make("intersection-v0", preset=preset, **{**overrides, "lidar_noise": 0.0})
    policy = make_policy(driver, env, seed=first_seed)
    recorder = _ObservationRecorder(env)
    for k in range(episodes):
        obs, infos = env.reset(seed=first_seed + k)
        recorder.observations = obs
        recorder.add(k, infos)
        while env.agents:
            obs, rewards, _, _, infos = env.step(policy.act({a: obs[a] for a in env.agents}))
            recorder.observations = obs
            recorder.add(k, infos, rewards)
    env.close()
    return recorder.table()


def check_spawns(nagents: int, overrides: dict[str, Any], preset: Optional[str]) -> None:
    """Refuse a comparison whose two worlds place cars by different rules: where our side sets an
    approach order the original has (``rotate`` is its ``balance_cars=True``, ``random`` its
    ``False``), it must be the one the original uses with ``nagents`` cars (round robin up to 4,
    random beyond: the 8-car command). Our default ``fixed`` order has no counterpart and is a
    listed difference of the default world, so it passes."""
    ours = _ours(overrides, preset).get("approach_order")
    theirs = "rotate" if OriginalRun(lidar_noise=0.0, epochs=1, nagents=nagents).balanced else "random"
    if ours in ("rotate", "random") and ours != theirs:
        raise OriginalError(
            f"approach_order={ours!r} on our side, but the original places {nagents} cars "
            f"{'round robin' if theirs == 'rotate' else 'each on a random approach'} "
            f"(balance_cars={theirs == 'rotate'}): add --set approach_order={theirs}")


def _ours(overrides: dict[str, Any], preset: Optional[str]) -> dict[str, Any]:
    """Our side's config values: the preset's, then ``overrides``."""
    from box2d_driving.presets import preset_overrides

    return {**(preset_overrides(preset, "intersection-v0") if preset else {}), **overrides}


def original_table(python: Path, worker: Path, driver: str, episodes: int, first_seed: int, nagents: int,
                   out: Path, turns: bool = False) -> dict[str, np.ndarray]:
    """The same in sdriving's world (the light runs' env settings for ``nagents`` cars, LiDAR
    noise 0: ``balance_cars`` as the original commands set it, see :attr:`OriginalRun.balanced`;
    ``turns``: its turning junction, :attr:`OriginalRun.turns`)."""
    spec = OriginalRun(lidar_noise=0.0, epochs=1, nagents=nagents, turns=turns).spec()
    spec_path = out.with_suffix(".run.json")
    spec_path.write_text(json.dumps(spec))
    partial = out.with_name(out.stem + ".partial.npz")  # a stopped rollout leaves no table at ``out``
    try:
        subprocess.run([str(python), str(worker), "rollout", str(spec_path), "--driver", driver,
                        "--episodes", str(episodes), "--first-seed", str(first_seed), "--out", str(partial),
                        "--target-fraction", repr(CONSTANT_SPEED_FRACTION)],
                       check=True, stderr=subprocess.DEVNULL)
    finally:
        spec_path.unlink()
    os.replace(partial, out)
    return load_table(out)


def comparison_rows(ours: dict[str, np.ndarray], original: dict[str, np.ndarray]) -> list[dict[str, Any]]:
    """One row per statistic both tables give: each world's value and half-width, and whether
    they agree within the interval of their difference."""
    a, b = world_statistics(original), world_statistics(ours)
    return [{"statistic": name, "original": a[name], "ours": b[name], "agree": agree(a[name], b[name])}
            for name in a if name in b]


def _cell(e: dict[str, Any]) -> str:
    return f"{e['value']:.3f} ± {e['half_width']:.3f} ({e['units']})"


def format_rows(driver: str, rows: Sequence[dict[str, Any]]) -> str:
    lines = [f"| {driver} | original | ours | agree |", "|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['statistic']} | {_cell(r['original'])} | {_cell(r['ours'])} | "
                     f"{'yes' if r['agree'] else '**no**'} |")
    return "\n".join(lines)


def compare(python: Path, worker: Path, drivers: Sequence[str], episodes: int, first_seed: int, nagents: int,
            overrides: dict[str, Any], out: Path, preset: Optional[str] = None) -> str:
    """Record both worlds per driver into ``out`` and return the markdown tables."""
    check_spawns(nagents, overrides, preset)
    turns = bool(_ours(overrides, preset).get("turns", False))  # the original's junction to match
    # tables already there, read and checked before anything is written
    kept = {path: kept_table(path, episodes) for driver in drivers for side in ("original", "ours")
            if (path := out / f"{side}_{driver}.npz").exists()}
    check_settings(out, {"episodes": episodes, "first_seed": first_seed, "cars": nagents, "preset": preset,
                         "overrides": overrides})
    parts = []
    for driver in drivers:
        theirs_path = out / f"original_{driver}.npz"
        theirs = kept.get(theirs_path) or original_table(python, worker, driver, episodes, first_seed, nagents,
                                                         theirs_path, turns)
        ours_path = out / f"ours_{driver}.npz"
        ours = kept.get(ours_path)
        if ours is None:
            ours = ours_table(driver, episodes, first_seed, {"num_cars": nagents, **overrides}, preset)
            save_table(ours, ours_path)
        parts.append(format_rows(driver, comparison_rows(ours, theirs)))
    return "\n\n".join(parts)


def kept_table(path: Path, episodes: int) -> dict[str, np.ndarray]:
    """A table an earlier comparison left in its ``--out`` folder, refused (:class:`OriginalError`)
    unless it holds ``episodes`` episodes: a table of another length is never read as this one."""
    table = load_table(path)
    held = len(np.unique(table["episode"]))
    if held != episodes:
        raise OriginalError(f"{path} holds {held} episodes, not the {episodes} asked for: give another "
                            f"--out, or --episodes {held} to read it")
    return table


def write_section(page: Path, name: str, text: str) -> None:
    """Write ``text`` (driver tables, as :func:`compare` returns them) between ``<!-- compare: NAME
    -->`` and ``<!-- /compare: NAME -->`` in ``page``: a driver's table there is replaced by its
    new one, the tables of drivers this run did not drive are kept, anything else in the section
    is dropped, and the tables stand in :data:`DRIVERS` order (the page is rewritten whole,
    through a temporary file)."""
    body = page.read_text()
    start, end = f"<!-- compare: {name} -->", f"<!-- /compare: {name} -->"
    if body.count(start) != 1 or body.count(end) != 1 or body.index(start) > body.index(end):
        raise ValueError(f"{page} has no single section '{start}' ... '{end}'")
    head, rest = body.split(start)
    old, tail = rest.split(end)
    tables = {**_driver_tables(old), **_driver_tables(text)}
    order = sorted(tables, key=lambda d: (DRIVERS.index(d) if d in DRIVERS else len(DRIVERS), d))
    tmp = page.with_name(page.name + ".partial")
    tmp.write_text(f"{head}{start}\n" + "\n\n".join(tables[d] for d in order) + f"\n{end}{tail}")
    tmp.replace(page)


def _driver_tables(text: str) -> dict[str, str]:
    """The driver tables in ``text`` by driver: blocks whose first line is ``| DRIVER | original |
    ours | agree |``."""
    out = {}
    for block in text.strip().split("\n\n"):
        cells = [c.strip() for c in block.strip().splitlines()[0].strip("|").split("|")] if block.strip() else []
        if len(cells) == 4 and cells[1:] == ["original", "ours", "agree"]:
            out[cells[0]] = block.strip()
    return out
