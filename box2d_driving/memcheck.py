"""Memory over resets: how much a process grows per 1,000 resets of each registered env.

Training runs reset their envs millions of times, so anything an episode leaves behind (an old
Box2D world, references held by fixtures, caches keyed by episode) adds up. For each env this
warms up (``warmup`` resets, so that allocator pools and lazily built tables exist), then runs
``resets`` more, each followed by ``steps`` decisions of random actions (so contacts, collisions
and wrecks happen), and reports the growth of the resident set size in MiB per 1,000 resets.

Usage: ``box2d-driving bench --memory [--resets 1000] [--steps 3] [--envs ID ...] [--json FILE]``.
"""

from __future__ import annotations

import gc
import json
import resource
import sys
from dataclasses import asdict, dataclass
from typing import Optional, Sequence

import numpy as np

import box2d_driving
from box2d_driving.cli_parser import OneLineParser


@dataclass
class MemoryResult:
    """Resident memory of one env before and after ``resets`` resets of ``steps_per_reset``
    steps each (MiB), and the growth per 1,000 resets."""

    env_id: str
    resets: int
    steps_per_reset: int
    rss_start_mib: float
    rss_end_mib: float
    mib_per_1000_resets: float


def rss_mib() -> float:
    """Resident set size now (Linux: /proc; elsewhere the peak, which can only overstate growth)."""
    try:
        with open("/proc/self/statm") as fh:
            pages = int(fh.read().split()[1])
        return pages * resource.getpagesize() / 2**20
    except OSError:
        peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        return peak / 2**20 if sys.platform == "darwin" else peak / 2**10


def _episodes(env, count: int, steps: int, first_seed: int, rng: np.random.Generator) -> None:
    for k in range(count):
        env.reset(seed=first_seed + k)
        for _ in range(steps):
            if not env.agents:
                break
            env.step({a: int(rng.integers(env.action_space(a).n)) for a in env.agents})


def reset_growth(env_id: str, resets: int = 1000, steps: int = 3, warmup: int = 200) -> MemoryResult:
    """RSS growth of one env over ``resets`` seeded resets (after ``warmup`` of them)."""
    env = box2d_driving.make(env_id)
    rng = np.random.default_rng(0)
    _episodes(env, warmup, steps, 0, rng)
    gc.collect()
    start = rss_mib()
    _episodes(env, resets, steps, warmup, rng)
    gc.collect()
    end = rss_mib()
    env.close()
    return MemoryResult(env_id, resets, steps, round(start, 1), round(end, 1),
                        round((end - start) * 1000.0 / resets, 3))


def main(argv: Optional[Sequence[str]] = None) -> int:
    """``box2d-driving bench --memory``: print (and optionally write) the growth table; returns the
    exit status."""
    p = OneLineParser(prog="box2d-driving bench --memory", description=__doc__.split("\n\n")[0])
    p.add_argument("--resets", type=int, default=1000, help="measured resets per env (default 1000)")
    p.add_argument("--steps", type=int, default=3, help="random decisions after each reset (default 3)")
    p.add_argument("--envs", nargs="+", default=None, help="env ids (default: every registered env)")
    p.add_argument("--json", help="also write the table to this JSON file")
    args = p.parse_args(argv)
    if args.resets < 1 or args.steps < 0:
        p.error("--resets must be >= 1 and --steps >= 0")
    envs = args.envs or list(box2d_driving.registry())
    unknown = [e for e in envs if e not in box2d_driving.registry()]
    if unknown:
        p.error(f"unknown env id(s) {unknown}; see `box2d-driving list`")
    rows = []
    print(f"{'env':<24} {'resets':>7} {'RSS start MiB':>14} {'RSS end MiB':>12} {'MiB / 1000 resets':>18}")
    for env_id in envs:
        r = reset_growth(env_id, args.resets, args.steps)
        rows.append(r)
        print(f"{r.env_id:<24} {r.resets:>7} {r.rss_start_mib:>14.1f} {r.rss_end_mib:>12.1f} "
              f"{r.mib_per_1000_resets:>18.2f}", flush=True)
    if args.json:
        with open(args.json, "x") as fh:  # never replaces an earlier table
            json.dump([asdict(r) for r in rows], fh, indent=2)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
