"""Compare lane-emergence evaluations: a markdown table and one histogram of normalised lane
position through the junction per run.

    python training/experiments/lanes_compare.py --out docs/images/lanes_histogram.png \\
        "8 cars, noise 0.5=runs/lanes8_n05/eval" "8 cars, noise 0=runs/lanes8_n0/eval" ...
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent.parent))

from box2d_driving.metrics.lanes import junction_lane_samples  # noqa: E402
from box2d_driving.metrics.rollouts import load_table  # noqa: E402
from training import plots  # noqa: E402


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("runs", nargs="+", help="LABEL=EVAL_FOLDER (with rollouts.npz and metrics.json)")
    parser.add_argument("--out", required=True, help="histogram PNG to write")
    args = parser.parse_args(argv)
    samples = {}
    print("| run | crossings | majority side | share of crossings | share of time | success | collision | violation |")
    print("|---|---:|---|---:|---:|---:|---:|---:|")
    for item in args.runs:
        label, folder = item.split("=", 1)
        folder = Path(folder)
        m = json.loads((folder / "metrics.json").read_text())
        lanes = m["lanes"]
        samples[label] = junction_lane_samples(load_table(folder / "rollouts.npz"))
        print(f"| {label} | {lanes['crossings']} | {lanes['majority_side']} | {lanes['majority_share']:.3f} | "
              f"{lanes['time_share_majority']:.3f} | {m['success_rate']:.3f} | {m['collision_rate']:.3f} | "
              f"{m['red_light_violation_rate']:.3f} |")
    out = Path(args.out)
    if out.exists():
        print(f"lanes_compare: error: {out} exists", file=sys.stderr)
        return 2
    plots.lane_histogram(samples, out)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
