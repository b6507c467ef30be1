"""Training throughput benchmark: ``box2d-driving bench --train``.

For each number of env worker processes (0 = in the learner's process, then 1, 2, 4, ... up to the
machine's cores), transport, rollout loop, thread count and LiDAR encoder asked for, and on the CPU and, where
torch sees one, the GPU, trains real PPO updates on ``intersection-v0`` and measures agent-steps
per second with the updates included (:mod:`training.trainers.bench_rows` defines every figure of
a row). The world and update are our defaults (4 cars, LiDAR noise 0.5, 16 env instances, 32,000
slot-decisions per update, minibatch 4,000, 4 epochs), or a named preset's (``--preset paper``:
the paper's own code, 20 instances, an update every 32,000 joint steps, one pass in 20
minibatches; docs/paper_world.md). Prints a table and writes it as JSON (``--json FILE``, never
replacing an existing file).
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
from dataclasses import asdict
from itertools import product
from pathlib import Path
from typing import Optional, Sequence

import torch as th

from box2d_driving import make
from box2d_driving.bench import machine
from box2d_driving.config import ConfigError
from box2d_driving.presets import preset_overrides

from training.common.cli_args import OneLineParser
from training.ppo.encoder import ENCODERS
from training.ppo.workers import worker_processes
from training.ppo.vec_env import TRANSPORTS
from training.trainers.bench_rows import TrainBenchRow, bench_row
from training.trainers.presets import TRAINING_PRESETS, training_preset
from training.trainers.train_config import DEVICES, TrainConfig
from training.trainers.trainer import resolve_device

ENV_ID = "intersection-v0"
JOINT_STEPS_PER_EPOCH = 32_000  # the original trainer's epoch (sdriving's steps_per_epoch), the table's time unit


def bench_config(*, cars: int, lidar_noise: float, num_cpus: int, transport: str, overlap: bool, device: str,
                 minibatch_by_step: bool, threads: Optional[int], n_envs: Optional[int] = None,
                 batch_decisions: Optional[int] = None, preset: Optional[str] = None,
                 lidar_encoder: Optional[str] = None) -> TrainConfig:
    """The training config of one row: our defaults, or ``preset``'s world and update
    (:func:`box2d_driving.presets.preset_overrides`, :meth:`TrainingPreset.apply`); ``n_envs``,
    ``batch_decisions`` and ``lidar_encoder`` replace the defaults' or the preset's when given (under
    a preset the minibatch stays its share of the batch: a 20th for ``paper``)."""
    overrides = {} if preset is None else preset_overrides(preset, ENV_ID)
    overrides.update({"num_cars": cars, "lidar_noise": lidar_noise})
    cfg = TrainConfig(env_id=ENV_ID, env_overrides=overrides, num_cpus=num_cpus, transport=transport,
                      overlap=overlap, device=device, minibatch_by_step=minibatch_by_step, threads=threads,
                      preset=preset)
    if preset is not None:
        chosen = training_preset(preset)
        chosen.apply(cfg, cars)
        chosen.resize(cfg, n_envs=n_envs, batch_decisions=batch_decisions)
    else:
        cfg.n_envs = cfg.n_envs if n_envs is None else n_envs
        cfg.batch_decisions = cfg.batch_decisions if batch_decisions is None else batch_decisions
    if lidar_encoder is not None:
        cfg.lidar_encoder = lidar_encoder
    cfg.validate()
    return cfg


def worker_counts(cores: int) -> list[int]:
    """0, 1, 2, 4, ... up to ``cores``."""
    out, n = [0, 1], 2
    while n <= cores:
        out.append(n)
        n *= 2
    if cores > 1 and out[-1] != cores:
        out.append(cores)
    return out


def distinct_worker_counts(counts: Sequence[int], n_envs: int) -> list[int]:
    """``counts`` without those that start as many worker processes as an earlier one (16
    instances over 12 workers start 8 processes of 2, as 8 workers do)."""
    seen: set[int] = set()
    out = []
    for n in counts:
        processes = worker_processes(n_envs, n)
        if processes not in seen:
            seen.add(processes)
            out.append(n)
    return out


def format_table(rows: list[TrainBenchRow]) -> str:
    """The markdown table ``bench --train`` prints, one row per measured setting."""
    lines = ["| env workers | transport | overlap | device | LiDAR encoder | torch threads: rollout / update | "
             "agent-steps/s (with updates) | s per epoch of 32,000 joint steps | "
             "limit: random actions, no learner | of limit | env | inference | update | "
             "ms per env step: env / inference / update "
             "| update GFLOP | update GFLOP/s | matmul GFLOP/s | of matmul | encoders free: GFLOP/s | of matmul |",
             "|---:|---|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|---:|---:|---:|---:|---:|---:|"]
    for r in rows:
        workers = f"{r.worker_processes}" + ("" if r.worker_processes == r.num_cpus else f" (of {r.num_cpus} asked)")
        epoch_s = f"{JOINT_STEPS_PER_EPOCH / r.joint_steps_per_s:,.0f}" if r.joint_steps_per_s else "n/a"
        of_limit = f"{r.agent_steps_per_s / r.limit_agent_steps_per_s:.0%}" if r.limit_agent_steps_per_s else "n/a"
        lines.append(f"| {workers} | {r.transport} | {'yes' if r.overlap else 'no'} | {r.device} | {r.lidar_encoder} | "
                     f"{r.threads} / {r.update_threads} | "
                     f"{r.agent_steps_per_s:,.0f} | {epoch_s} | "
                     f"{r.limit_agent_steps_per_s:,.0f} | {of_limit} | "
                     f"{r.env_share:.0%} | {r.inference_share:.0%} | {r.update_share:.0%} | "
                     f"{r.env_ms:.2f} / {r.inference_ms:.2f} / {r.update_ms:.2f} | "
                     f"{r.update_gflop:.1f} | {r.update_gflops:.1f} | {r.matmul_gflops:.0f} | "
                     f"{r.update_gflops / r.matmul_gflops:.0%} | {r.bound_gflops:.1f} | "
                     f"{r.bound_gflops / r.matmul_gflops:.0%} |")
    return "\n".join(lines)


def main(argv: Optional[Sequence[str]] = None) -> int:
    """``box2d-driving bench --train``: measure every requested worker count and print the table;
    returns the exit status."""
    p = OneLineParser(prog="box2d-driving bench --train", description=__doc__.split("\n\n")[0])
    p.add_argument("--cars", type=int, default=4, help="cars per instance (default 4)")
    p.add_argument("--lidar-noise", type=float, default=0.5, help="LiDAR noise (default 0.5)")
    p.add_argument("--n-envs", type=int, help="env instances (default 16, or the preset's: 20 for paper)")
    p.add_argument("--batch-decisions", type=int,
                   help="slot-decisions per update (default 32,000, or the preset's: 32,000 joint steps x --cars "
                        "for paper)")
    p.add_argument("--preset", choices=sorted(TRAINING_PRESETS),
                   help="a named preset's world and update instead of our defaults (paper: the paper's own code, "
                        "docs/paper_world.md)")
    p.add_argument("--warmup", type=int, default=1, help="untimed updates first (default 1)")
    p.add_argument("--updates", type=int, default=2, help="timed updates (default 2)")
    p.add_argument("--num-cpus", type=int, nargs="+", help="worker counts (default 0, 1, 2, 4, ... cores)")
    p.add_argument("--transport", nargs="+", choices=TRANSPORTS, default=["shared"],
                   help="how the env worker processes hand each step over, each a row per worker count above 0 "
                        "(default shared; supersuit: SuperSuit's ProcConcatVec)")
    p.add_argument("--overlap", nargs="+", choices=("on", "off"), default=["on"],
                   help="the overlapped rollout loop (on, the default) or SB3's (off), each a row per worker "
                        "count above 0")
    p.add_argument("--threads", type=int, nargs="+",
                   help="torch threads of the learner, rollouts and update alike, each a row per worker count "
                        "(default: as training sets them: while collecting the cores the env worker processes "
                        "leave free, during the update every core)")
    p.add_argument("--lidar-encoder", nargs="+", choices=ENCODERS,
                   help="the actor's and critic's LiDAR encoder, each a row per setting (default: training's, "
                        "original: the paper code's; relu: ours before 2026-12-06)")
    p.add_argument("--devices", "--device", nargs="+", choices=DEVICES,
                   help="devices (default: cpu, and cuda when torch sees a GPU; auto: the GPU when "
                        "torch sees one, else the CPU, as train --device auto)")
    p.add_argument("--minibatch-by-step", action=argparse.BooleanOptionalAction, default=True,
                   help="minibatches of whole env steps (default; --no-minibatch-by-step: by transition)")
    p.add_argument("--json", help="also write the table to this JSON file (must not exist)")
    args = p.parse_args(argv)
    given = [v for v in (args.n_envs, args.batch_decisions) if v is not None]
    if min([args.cars, args.updates, *given]) < 1 or args.warmup < 0:
        p.error("--cars, --n-envs, --batch-decisions and --updates must be >= 1, --warmup >= 0")
    if args.threads and min(args.threads) < 1:
        p.error(f"--threads must be >= 1, got {min(args.threads)}")
    if args.json and Path(args.json).exists():
        p.error(f"{args.json} exists; choose another --json")

    def config(n: int, transport: str, overlap: bool, device: str, threads: Optional[int],
               encoder: Optional[str] = None) -> TrainConfig:
        return bench_config(cars=args.cars, lidar_noise=args.lidar_noise, num_cpus=n, transport=transport,
                            overlap=overlap, device=device, minibatch_by_step=args.minibatch_by_step,
                            threads=threads, n_envs=args.n_envs, batch_decisions=args.batch_decisions,
                            preset=args.preset, lidar_encoder=encoder)

    try:  # what every row shares: checked (the world's settings too) and printed before anything runs
        first = config(0, args.transport[0], False, "cpu", None)
        make(ENV_ID, **first.env_overrides).close()
    except ConfigError as exc:
        p.error(str(exc))
    cores = os.cpu_count() or 1
    counts = args.num_cpus or distinct_worker_counts(worker_counts(cores), first.n_envs)
    if "cuda" in (args.devices or ()) and not th.cuda.is_available():
        p.error("--devices cuda: torch sees no GPU (a CPU-only torch build, or no driver); use auto or cpu")
    devices = args.devices or (["cpu", "cuda"] if th.cuda.is_available() else ["cpu"])
    devices = list(dict.fromkeys(resolve_device(d) for d in devices))  # auto -> cpu or cuda, once
    world = "our defaults" if args.preset is None else f"preset {args.preset}"
    print(f"training benchmark: {ENV_ID} ({world}), {args.cars} cars, noise {args.lidar_noise}, {first.n_envs} "
          f"instances, {first.batch_decisions:,} slot-decisions per update ({first.epochs} epoch(s) of minibatch "
          f"{first.minibatch:,}), {args.warmup} warm-up + {args.updates} timed updates; {cores} cores, python "
          f"{platform.python_version()}, torch {th.__version__}", flush=True)
    rows = []
    for device in devices:
        for n in counts:
            ways = [(t, o) for t in args.transport for o in args.overlap] if n else [(args.transport[0], "off")]
            for transport, overlap in ways:
                for threads, encoder in product(args.threads or [None], args.lidar_encoder or [None]):
                    row = bench_row(config(n, transport, overlap == "on", device, threads, encoder), args.warmup,
                                    args.updates)
                    rows.append(row)
                    print(f"  workers {row.worker_processes:>2} ({row.transport}, overlap {overlap}), {device}, "
                          f"encoder {row.lidar_encoder}, "
                          f"{row.threads} / {row.update_threads} threads: {row.agent_steps_per_s:,.0f} agent-steps/s "
                          f"(limit {row.limit_agent_steps_per_s:,.0f}), "
                          f"{JOINT_STEPS_PER_EPOCH / row.joint_steps_per_s:,.0f} s per epoch of "
                          f"{JOINT_STEPS_PER_EPOCH:,} joint steps", flush=True)
    print()
    print(format_table(rows))
    gpu = th.cuda.get_device_name(0) if th.cuda.is_available() else "no GPU"
    print(f"machine: {machine()}, {gpu}")
    if args.json:
        with open(args.json, "x") as fh:
            json.dump({"settings": vars(args), "cores": cores, "machine": f"{machine()}, {gpu}",
                       "rows": [asdict(r) for r in rows]}, fh, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
