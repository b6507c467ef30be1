"""Evaluate every kept checkpoint of a run: success, collisions, right of way (FIFO share) and the
safe-distance share against agent-steps, as a CSV and a plot (the learning curve of the rules).
Choosing a checkpoint from this curve is a selection, so it runs on selection seeds; report the
chosen checkpoint with ``evaluate``, on report seeds.

    python training/evaluation/checkpoint_curve.py runs/real_junction --episodes 20
"""

from __future__ import annotations

import argparse
import csv
import re
import sys
from pathlib import Path

import numpy as np

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parents[2]))  # the repository root

from box2d_driving.metrics.rollouts import run_episodes  # noqa: E402
from training.evaluation import plots  # noqa: E402
from training.runs.inference import load_policy  # noqa: E402
from training.evaluation.reports import junction_summary  # noqa: E402
from training.common.cli_args import error  # noqa: E402
from training.common.seeds import SELECTION  # noqa: E402

FIELDS = ("decisions", "agent_steps", "success_rate", "collision_rate", "fifo_share", "safe_share")


def agent_steps_at(run: Path, decisions: np.ndarray) -> np.ndarray:
    """Agent-steps at the given slot-decision counts, interpolated from the run's progress logs."""
    progress = plots.read_progress(run)
    if progress is None or "time/agent_steps" not in progress:
        return np.full(len(decisions), np.nan)
    return np.interp(decisions, progress["time/total_timesteps"], progress["time/agent_steps"])


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("run", type=Path, help="run folder with checkpoints/model_<decisions>.safetensors")
    parser.add_argument("--episodes", type=int, default=20, help="episodes per checkpoint")
    parser.add_argument("--seed", type=int, default=SELECTION.start,
                        help="first episode seed: selection seeds (choosing a checkpoint is a selection; "
                             "report the chosen one with evaluate, on report seeds)")
    parser.add_argument("--out", type=Path, help="output folder (default RUN/checkpoint_curve)")
    parser.add_argument("--overwrite", action="store_true")
    args = parser.parse_args(argv)
    try:
        SELECTION.episodes(args.episodes, args.seed)
    except ValueError as exc:
        return error(str(exc))
    import torch

    torch.set_num_threads(1)
    out = args.out or args.run / "checkpoint_curve"
    if out.exists() and any(out.iterdir()) and not args.overwrite:
        return error(f"{out} is not empty; pass --overwrite")
    ckpts = sorted(args.run.glob("checkpoints/model_*.safetensors"), key=lambda p: int(re.findall(r"\d+", p.stem)[-1]))
    if not ckpts:
        return error(f"no checkpoints in {args.run / 'checkpoints'}")
    out.mkdir(parents=True, exist_ok=True)
    decisions = np.array([int(re.findall(r"\d+", p.stem)[-1]) for p in ckpts], dtype=float)
    steps = agent_steps_at(args.run, decisions)
    rows = []
    for path, d, s in zip(ckpts, decisions, steps):
        policy = load_policy(path)
        env = policy.make_env()
        table = run_episodes(env, policy, args.episodes, seed=args.seed)
        row = {"decisions": int(d), "agent_steps": float(s), **junction_summary(table, env.config)}
        rows.append(row)
        print(" ".join(f"{k}={v:.3f}" if isinstance(v, float) else f"{k}={v}" for k, v in row.items()), flush=True)
    with open(out / "curve.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=FIELDS)
        writer.writeheader()
        writer.writerows(rows)
    x = np.array([r["agent_steps"] for r in rows])
    if np.isnan(x).any():
        x = decisions
    plots.metric_over_training(x, {k: np.array([r[k] for r in rows]) for k in FIELDS[2:]},
                               out / "curve.png", "share", reference=(0.8525, "paper FIFO 85.25 %"))
    print(f"wrote {out / 'curve.csv'} and {out / 'curve.png'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
