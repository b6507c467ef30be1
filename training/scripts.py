"""Shared CLI of the training scripts: a dataclass of arguments, turned into a TrainConfig."""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Optional

from training.cli_args import parse
from training.trainer import RunError, TrainConfig, train


@dataclass
class ScriptArgs:
    """Arguments every training script takes.

    num_cars: cars per episode
    lidar_noise: share of LiDAR rays dropped each decision
    timesteps: slot-decisions to train for in total
    seed: random seed
    quick: a real but short run (about a minute of training here)
    out: output folder (must not exist unless --resume)
    resume: continue the run in --out from its last checkpoint
    ent_coef: entropy bonus (default: 0.01)
    critic: mean (the paper), own+mean, or own (decentralised baseline)
    n_envs: env instances simulated side by side
    batch_decisions: slot-decisions per PPO update
    epochs: PPO epochs per update
    threads: torch CPU threads
    max_minutes: stop once the run has trained this many wall-clock minutes (all sessions)
    init_from: start from this checkpoint's weights (e.g. fine-tune a 4-car policy with 8 cars)
    horizon: episode horizon in decisions (default: the scenario's)
    """

    num_cars: int = 4
    lidar_noise: float = 0.0
    timesteps: int = 3_000_000
    seed: int = 0
    quick: bool = False
    out: str = "runs/run"
    resume: bool = False
    ent_coef: Optional[float] = None
    critic: str = "mean"
    n_envs: int = 16
    batch_decisions: int = 32_000
    epochs: int = 4
    threads: int = 2
    max_minutes: Optional[float] = None
    init_from: Optional[str] = None
    horizon: Optional[int] = None


def config_from(env_id: str, args: ScriptArgs) -> TrainConfig:
    overrides = {"num_cars": args.num_cars, "lidar_noise": args.lidar_noise}
    if args.horizon is not None:
        overrides["horizon"] = args.horizon
    cfg = TrainConfig(
        env_id=env_id, env_overrides=overrides, timesteps=args.timesteps, seed=args.seed,
        n_envs=args.n_envs, batch_decisions=args.batch_decisions, epochs=args.epochs,
        critic=args.critic, threads=args.threads, max_minutes=args.max_minutes,
        init_from=args.init_from,
        ent_coef=0.01 if args.ent_coef is None else args.ent_coef,
    )
    if args.quick:  # same algorithm, smaller numbers
        cfg.n_envs, cfg.batch_decisions, cfg.minibatch = 8, 8_000, 2_000
        cfg.timesteps = min(args.timesteps, 48_000)
        cfg.checkpoint_every = 2
    return cfg


def run_script(env_id: str, args_class: type, argv: Optional[list[str]], doc: str) -> int:
    """Parse ``argv`` into ``args_class``, train, print a summary; exit status."""
    name = Path(sys.argv[0]).stem
    args = parse(args_class, argv, description=(doc or "").split("\n\n")[0])
    try:
        stats = train(config_from(env_id, args), Path(args.out), resume=args.resume)
    except (RunError, ValueError) as exc:
        print(f"{name}: error: {exc}", file=sys.stderr)
        return 2
    print("last update:", {k.split("/")[-1]: round(v, 4) if isinstance(v, float) else v
                           for k, v in stats.items()})
    print(f"checkpoint: {Path(args.out) / 'model.zip'}")
    return 0
