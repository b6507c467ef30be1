"""``box2d-driving check-shipped``: does every shipped policy hold its reported numbers on a fresh
block of report episodes?

A policy's report (``assets/policies/NAME/eval/metrics.json``, the numbers in the README) was
measured on one block of report seeds; that block is a sample, not the target. This command drives
each shipped policy on another block of report seeds, as many episodes, and sets each reported
rate against the fresh one (the reported block is driven again too: it must give the reported
numbers, and it gives their interval):

    box2d-driving check-shipped                                   # every shipped policy, seeds 1,700,000,000+
    box2d-driving check-shipped --only traffic_lights_4cars_noise05 --seed 1800000000 --out check.md

Each rate gets a 95 % interval with episodes as clusters
(:func:`box2d_driving.metrics.intervals.clustered_share`); ``z`` is the difference of the two
blocks' rates in units of its standard error (the two blocks' errors added in quadrature). A rate
*holds* when ``|z| <= 1.96``. With some thirty rates checked, one or two beyond 1.96 are expected
by chance alone.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path
from typing import Any, Optional

from box2d_driving.single_agent import SHIPPED
from box2d_driving.metrics.intervals import RATES, Z95, rate_intervals
from box2d_driving.metrics.rollouts import run_episodes
from training.common.cli_args import OneLineParser, error, prog_name
from training.common.seeds import REPORT

__all__ = ["FRESH_SEED", "check_policy", "main", "markdown", "shipped_reports"]

# the first seed of the default fresh block: report seeds, far from the first block (1,500,000,000)
FRESH_SEED = 1_700_000_000


class CheckError(ValueError):
    """A check that cannot run: blocks that overlap, seeds off the report range, no such policy."""


def shipped_reports(root: Path = SHIPPED) -> dict[str, Path]:
    """Policy name (its folder under ``root``) -> its report, for every shipped policy with a
    checkpoint (the communication study also keeps reports of runs whose policy is not shipped)."""
    found = {}
    for report in sorted(Path(root).glob("**/eval/metrics.json")):
        run = report.parent.parent
        if (run / "model.safetensors").exists() or (run / "accel").is_dir():
            found[run.relative_to(root).as_posix()] = report
    return found


def check_policy(report: Path, first_seed: int, episodes: Optional[int] = None) -> list[dict[str, Any]]:
    """One row per rate the report states: its value there, the fresh block's value with its
    clustered half-width, ``z`` and whether it holds."""
    from training.runs.inference import load_policy

    recorded = json.loads(Path(report).read_text())
    n = episodes or int(recorded["episodes"])
    try:
        fresh = REPORT.episodes(n, first_seed)
    except ValueError as exc:
        raise CheckError(str(exc)) from None
    old = range(int(recorded["seed"]), int(recorded["seed"]) + int(recorded["episodes"]))
    if fresh.start < old.stop and old.start < fresh.stop:
        raise CheckError(f"episodes {fresh.start:,}..{fresh.stop - 1:,} overlap the reported block "
                         f"{old.start:,}..{old.stop - 1:,} of {report}: choose another --seed")
    policy = load_policy(Path(report).parent.parent)
    env = policy.make_env(**recorded.get("env_config", {}))  # the settings the report was measured with
    names = tuple(r for r in RATES if isinstance(recorded.get(r), (int, float)) and math.isfinite(recorded[r]))
    # the reported block again (same seeds, same policy: it must give the reported numbers) for its
    # clustered error, and the fresh block
    again = rate_intervals(run_episodes(env, policy, len(old), seed=old.start), names)
    rows = []
    for name, got in rate_intervals(run_episodes(env, policy, n, seed=fresh.start), names).items():
        se = math.hypot(got["se"], again[name]["se"])  # of the difference of two independent blocks
        diff = got["value"] - recorded[name]
        z = diff / se if se > 0 else (0.0 if diff == 0 else math.copysign(math.inf, diff))
        rows.append({"metric": name, "reported": float(recorded[name]), "reported_first_seed": old.start,
                     "reported_episodes": len(old), "reported_half_width": again[name]["half_width"],
                     "reproduced": bool(abs(again[name]["value"] - recorded[name]) <= 1e-9),
                     "episodes": n, "fresh": got["value"], "fresh_half_width": got["half_width"],
                     "fresh_first_seed": fresh.start, "z": z, "holds": bool(abs(z) <= Z95)})
    return rows


def markdown(results: dict[str, list[dict[str, Any]]]) -> str:
    """The check as a Markdown table, one row per policy and rate."""
    lines = ["| policy | rate | reported block | fresh block | z | holds |", "|---|---|---|---|---|---|"]
    for name, rows in results.items():
        for r in rows:
            reported = f"{r['reported']:.3f} ± {r['reported_half_width']:.3f}" + ("" if r["reproduced"] else
                                                                                 " (**not reproduced here**)")
            lines.append(f"| `{name}` | {r['metric']} | {reported} | {r['fresh']:.3f} ± {r['fresh_half_width']:.3f} | "
                         f"{r['z']:+.2f} | {'yes' if r['holds'] else '**no**'} |")
    rows = [r for rs in results.values() for r in rs]
    blocks = sorted({(r["reported_first_seed"], r["reported_episodes"], r["fresh_first_seed"], r["episodes"])
                     for r in rows})
    said = "; ".join(f"reported block seeds {a:,}+ ({m} episodes), fresh block {b:,}+ ({n} episodes)"
                     for a, m, b, n in blocks)
    return ("\n".join(lines) + f"\n\nBlocks: {said}. Intervals: 95 %, episodes as clusters. "
            f"{sum(r['holds'] for r in rows)} of {len(rows)} rates hold (|z| <= 1.96; about 1 in 20 misses by "
            f"chance); {sum(r['reproduced'] for r in rows)} of {len(rows)} reported values reproduced exactly on the "
            "reported block.\n")


def page(table: str, argv: list[str]) -> str:
    """The check as a page: what it is, the command that wrote it, the table."""
    command = " ".join(["box2d-driving check-shipped", *argv])
    return ("# Shipped policies on fresh episodes\n\n"
            "Written by `box2d-driving check-shipped`; do not edit by hand. Each shipped policy's report (the "
            "numbers in the table of [the shipped policies](policies.md)) was measured on one block of report episode "
            "seeds. Here each policy drives another block of report seeds, as many episodes, and each reported "
            "rate is set against the fresh one. The interval is 95 % with episodes as clusters (the cars of one "
            "episode share its traffic, so they are not independent draws); `z` is the difference of the two "
            "blocks in units of its standard error, and a rate holds at |z| <= 1.96. A single policy is one "
            "training seed: how much a rule varies between training seeds is on the [results page](results.md).\n\n"
            f"```bash\n{command}\n```\n\n" + table)


def main(argv: Optional[list[str]] = None) -> int:
    p = OneLineParser(prog=prog_name(), description=__doc__.split("\n\n")[0])
    p.add_argument("--seed", type=int, default=FRESH_SEED,
                   help=f"first seed of the fresh block, a report seed (default {FRESH_SEED:,})")
    p.add_argument("--episodes", type=int, help="episodes in the fresh block (default: as many as the report's)")
    p.add_argument("--only", nargs="+", metavar="NAME", help="these shipped policies only (folders under "
                                                                "assets/policies)")
    p.add_argument("--out", type=Path, help="also write the table here (Markdown) and the rows beside it (.json)")
    args = p.parse_args(argv)
    reports = shipped_reports()
    unknown = [n for n in args.only or () if n not in reports]
    if unknown:
        return error(f"--only: no shipped policy {', '.join(unknown)}; shipped: {', '.join(reports)}")
    if args.episodes is not None and args.episodes < 1:
        return error(f"--episodes must be >= 1, got {args.episodes}")
    import torch

    torch.set_num_threads(1)
    results = {}
    for name, report in reports.items():
        if args.only and name not in args.only:
            continue
        try:
            results[name] = check_policy(report, args.seed, args.episodes)
        except CheckError as exc:
            return error(f"{name}: {exc}")
        for r in results[name]:
            print(f"{name}: {r['metric']} reported {r['reported']:.3f}"
                  f"{'' if r['reproduced'] else ' (NOT reproduced)'}, fresh {r['fresh']:.3f} ± "
                  f"{r['fresh_half_width']:.3f}, z {r['z']:+.2f}: {'holds' if r['holds'] else 'MOVES'}", flush=True)
    text = markdown(results)
    print(text)
    if args.out is not None:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(page(text, argv if argv is not None else sys.argv[1:]))
        args.out.with_suffix(".json").write_text(json.dumps(results, indent=2))
    return 0 if all(r["holds"] for rows in results.values() for r in rows) else 1


if __name__ == "__main__":
    raise SystemExit(main())
