"""Learning curves of a rule's metrics on selection seeds: every kept checkpoint of a run (or of
every trial of a sweep) driven on the same selection episodes, as a CSV and a plot, and whether
each metric had stopped moving by the end of training (:func:`late_change`).

Choosing a checkpoint or a budget from these curves is a selection, so they run on selection
seeds; report the chosen policy with ``evaluate``, on report seeds.

    box2d-driving curve runs/real_junction --episodes 20          # one run: RUN/checkpoint_curve/
    box2d-driving curve runs/sweep-lights-paper --episodes 100    # every trial: OUT/curves.csv
                                                                  # (training/sweeps/curves.py)

Which metrics a curve follows depends on the scenario the run trained on (:func:`curve_metrics`, its record's):
success and collisions always, plus the scenario's rule (red-light violations, pedestrians,
right of way and safe distance, the message, lanes, fast lanes). A bilevel run (lanes, fast
lanes) is drawn from its kept rounds, each round's acceleration and spline policies together.
"""

from __future__ import annotations

import csv
import json
import re
from pathlib import Path
from typing import Any, Callable, Collection, Optional

import numpy as np

from box2d_driving.config import ConfigError
from box2d_driving.metrics.rollouts import run_episodes
from box2d_driving.scenarios import scenario
from box2d_driving.policies.checkpoint_file import is_bilevel_run
from training.common.cli_args import OneLineParser, error, prog_name
from training.common.seeds import SELECTION
from training.evaluation import plots

# the share of a run's training whose trend says whether a metric had stopped moving
LATE_SHARE = 0.5


class CurveError(ValueError):
    """A run or sweep folder a curve cannot be drawn for (no checkpoints, an unknown scenario, ...)."""


def curve_metrics(env_id: str) -> tuple[str, ...]:
    """The metrics a curve of ``env_id`` follows: success, collisions and its scenario record's
    ``curve_metrics`` (:mod:`box2d_driving.scenarios`)."""
    return scenario(env_id).curve()


def rule_metrics(env_id: str, table: dict, config: Any) -> dict[str, float]:
    """The curve's metrics (:func:`curve_metrics`, and any more its scenario measures with the
    options of ``config``, e.g. the message's) of one checkpoint's episodes."""
    return scenario(env_id).measure(table, config)


def kept_checkpoints(run: Path) -> list[dict[str, Any]]:
    """Every kept checkpoint of a run, in training order: ``decisions`` and how to load it
    (``file``; for a bilevel run ``round``, its acceleration and spline checkpoints of that round)."""
    if is_bilevel_run(run):
        config = json.loads((run / "config.json").read_text())
        per_round = int(config["accel_updates_per_round"]) * int(config["accel"]["batch_decisions"])
        found: list[dict[str, Any]] = [{"round": int(re.findall(r"\d+", p.stem)[0]), "file": p}
                 for p in run.glob("checkpoints/round_*_accel.safetensors")]
        for f in found:
            f["decisions"] = f["round"] * per_round
    else:
        found = [{"decisions": int(re.findall(r"\d+", p.stem)[-1]), "file": p}
                 for p in run.glob("checkpoints/model_*.safetensors")]
    if not found:
        raise CurveError(f"no checkpoints in {run / 'checkpoints'} (model_<decisions>.safetensors, or a bilevel "
                         "run's round_<r>_accel.safetensors)")
    return sorted(found, key=lambda f: f["decisions"])


def agent_steps_at(run: Path, decisions: np.ndarray) -> np.ndarray:
    """Agent-steps at the given slot-decision counts, interpolated from the run's progress logs
    (a bilevel run: its acceleration stage's)."""
    progress = plots.read_progress(run) or plots.read_progress(run / "accel")
    if progress is None or "time/agent_steps" not in progress:
        return np.full(len(decisions), np.nan)
    return np.interp(decisions, progress["time/total_timesteps"], progress["time/agent_steps"])


def run_curve(run: Path, episodes: int, seed: int, log: Callable[[str], None] = lambda line: None,
              skip: Collection[int] = ()) -> list[dict[str, Any]]:
    """One row per kept checkpoint of ``run`` (less those at the decisions in ``skip``, drawn
    already): decisions, agent-steps and the scenario's curve metrics on ``episodes`` episodes
    from selection seed ``seed`` (the same episodes for every checkpoint, so the curve's steps are
    the policy's, not the episodes')."""
    from training.runs.inference import load_bilevel_round, load_policy

    ckpts = [c for c in kept_checkpoints(run) if c["decisions"] not in set(skip)]
    steps = agent_steps_at(run, np.array([c["decisions"] for c in ckpts], dtype=float))
    rows = []
    for c, agent_steps in zip(ckpts, steps):
        policy = load_bilevel_round(run, c["round"]) if "round" in c else load_policy(c["file"])
        env = policy.make_env()
        try:
            scenario(policy.env_id)
        except ConfigError as exc:
            raise CurveError(f"{run}: {exc}") from None
        table = run_episodes(env, policy, episodes, seed=seed)
        row = {"decisions": c["decisions"], **({"round": c["round"]} if "round" in c else {}),
               "agent_steps": float(agent_steps), "episodes": episodes, "first_seed": seed,
               **rule_metrics(policy.env_id, table, env.config)}
        rows.append(row)
        log(" ".join(f"{k}={v:.3f}" if isinstance(v, float) else f"{k}={v}" for k, v in row.items()))
    return rows


def late_change(decisions: np.ndarray, values: np.ndarray, share: float = LATE_SHARE) -> float:
    """How much a metric moved over the last ``share`` of training: the least-squares slope
    through the checkpoints at or after ``(1 - share)`` of the last one's decisions, times that
    span (metric units). NaN with fewer than two such checkpoints. Defined before the
    paper-settings runs were looked at; averaged over seeds it says whether a curve had stopped
    moving (an interval around 0) or was still moving (an interval away from 0)."""
    d, v = np.asarray(decisions, dtype=float), np.asarray(values, dtype=float)
    ok = np.isfinite(v)
    d, v = d[ok], v[ok]
    if len(d) < 2:
        return float("nan")
    start = (1.0 - share) * d.max()
    late = d >= start - 1e-9
    if late.sum() < 2:
        return float("nan")
    change = float(np.polyfit(d[late], v[late], 1)[0] * (d.max() - start))
    return 0.0 if abs(change) < 1e-12 else change  # a flat curve's rounding error is no trend


def write_rows(path: Path, rows: list[dict[str, Any]]) -> None:
    """``rows`` as CSV at ``path``, the columns in the order they first appear."""
    fields: list[str] = []
    for r in rows:
        fields += [k for k in r if k not in fields]
    with open(path, "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=fields)
        writer.writeheader()
        writer.writerows(rows)


def curve_of_run(run: Path, out: Path, episodes: int, seed: int) -> None:
    """Every kept checkpoint of ``run`` evaluated on ``episodes`` episodes from ``seed``:
    ``curve.csv`` and a plot of each metric against training progress in ``out``."""
    rows = run_curve(run, episodes, seed, log=lambda line: print(line, flush=True))
    write_rows(out / "curve.csv", rows)
    x = np.array([r["agent_steps"] for r in rows])
    if np.isnan(x).any():
        x = np.array([r["decisions"] for r in rows], dtype=float)
    names = [k for k in rows[0] if k not in ("decisions", "round", "agent_steps", "episodes", "first_seed")]
    reference = (0.8525, "paper FIFO 85.25 %") if "right_of_way.fifo_share" in names else None
    plots.metric_over_training(x, {k: np.array([r[k] for r in rows]) for k in names},
                               out / "curve.png", "share", reference=reference)
    print(f"wrote {out / 'curve.csv'} and {out / 'curve.png'}")


def build_parser(what: str) -> Any:
    """The command line of ``box2d-driving curve`` (``what``: the folders it takes, in words)."""
    parser = OneLineParser(prog=prog_name(), description=__doc__.split("\n\n")[0])
    parser.add_argument("run", type=Path, help=what)
    parser.add_argument("--episodes", type=int, default=20, help="episodes per checkpoint (default 20)")
    parser.add_argument("--seed", type=int, default=SELECTION.start,
                        help="first episode seed: selection seeds (choosing a checkpoint is a selection; "
                             "report the chosen one with evaluate, on report seeds)")
    parser.add_argument("--out", type=Path, help="output folder (default RUN/checkpoint_curve, or the sweep folder)")
    parser.add_argument("--overwrite", action="store_true")
    return parser


def checked_out(args: Any, name: str, default: Path) -> Optional[Path]:
    """The output folder for ``name`` (``curve.csv``, ``curves.csv``), or None after printing the
    error: episodes off the selection range, or a curve already there without ``--overwrite``."""
    try:
        SELECTION.episodes(args.episodes, args.seed)
    except ValueError as exc:
        error(str(exc))
        return None
    out = args.out or default
    if (out / name).exists() and not args.overwrite:
        error(f"{out / name} exists; pass --overwrite")
        return None
    return out


def main(argv: Optional[list[str]] = None) -> int:
    """One run's curve (``box2d-driving curve`` also takes a sweep folder:
    :mod:`training.sweeps.curves`)."""
    args = build_parser("run folder with checkpoints/model_<decisions>.safetensors").parse_args(argv)
    out = checked_out(args, "curve.csv", args.run / "checkpoint_curve")
    return draw_into(out, lambda folder: curve_of_run(args.run, folder, args.episodes, args.seed))


def draw_into(out: Optional[Path], draw: Callable[[Path], None]) -> int:
    """A curve command's last step: ``draw`` into the folder ``out`` (made here), one torch thread
    (the rollouts are small); the exit status, a :class:`CurveError` printed as one line. ``out``
    None: :func:`checked_out` refused it and said why."""
    if out is None:
        return 2
    import torch

    torch.set_num_threads(1)
    out.mkdir(parents=True, exist_ok=True)
    try:
        draw(out)
    except CurveError as exc:
        return error(str(exc))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
