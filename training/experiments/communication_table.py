"""Compare communication evaluations across LiDAR noise levels (SPEC 6.4): markdown tables (the
metrics, and what each bit value says) and a plot of speaker consistency and the heading-change /
bit correlations against noise.

    python training/experiments/communication_table.py --out docs/images/communication.png \\
        0=runs/comm_n0/eval 0.25=runs/comm_n025/eval 0.5=runs/comm_n05/eval 0.75=runs/comm_n075/eval
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import numpy as np

if __package__ in (None, ""):
    sys.path.insert(0, str(Path(__file__).resolve().parent.parent.parent))

from training import plots  # noqa: E402

KEYS = (("speaker_consistency_bits", "speaker consistency (bits)"),
        ("pearson_heading_change_bit", "Pearson(heading change, bit)"),
        ("pearson_abs_heading_change_bit", "Pearson(|heading change|, bit)"))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("runs", nargs="+", help="NOISE=EVAL_FOLDER (with metrics.json)")
    parser.add_argument("--out", required=True, help="plot PNG to write")
    args = parser.parse_args(argv)
    rows = []
    for item in args.runs:
        noise, folder = item.split("=", 1)
        m = json.loads((Path(folder) / "metrics.json").read_text())
        if "communication" not in m:
            print(f"communication_table: error: {folder} was not evaluated with communication", file=sys.stderr)
            return 2
        if "by_bit" not in m["communication"]:
            print(f"communication_table: error: {folder} predates the per-bit profile; re-evaluate it "
                  "(training/evaluate.py --overwrite)", file=sys.stderr)
            return 2
        rows.append((float(noise), m))
    rows.sort(key=lambda r: r[0])
    print("| LiDAR noise | bit = 1 share | speaker consistency (bits) | Pearson(dh, bit) | Pearson(abs dh, bit) "
          "| success | collisions | FIFO share | safe-distance share |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for noise, m in rows:
        c = m["communication"]
        print(f"| {noise} | {c['bit_one_share']:.3f} | {c['speaker_consistency_bits']:.4f} | "
              f"{c['pearson_heading_change_bit']:.3f} | {c['pearson_abs_heading_change_bit']:.3f} | "
              f"{m['success_rate']:.3f} | {m['collision_rate']:.3f} | {m['right_of_way']['fifo_share']:.3f} | "
              f"{m['safety_distance']['safe_share']:.3f} |")
    print()
    print("What each value says (sender's means over the decisions it sent it; bit 0 / bit 1):")
    print()
    print("| LiDAR noise | speed (m/s) | next acceleration (m/s²) | abs heading change (rad) |")
    print("|---:|---:|---:|---:|")
    for noise, m in rows:
        b0, b1 = m["communication"]["by_bit"]["0"], m["communication"]["by_bit"]["1"]
        print(f"| {noise} | {b0['speed_mean']:.2f} / {b1['speed_mean']:.2f} | "
              f"{b0['next_accel_mean']:.2f} / {b1['next_accel_mean']:.2f} | "
              f"{b0['abs_heading_change_mean']:.3f} / {b1['abs_heading_change_mean']:.3f} |")
    plt = plots._plt()
    fig, ax = plt.subplots(figsize=(6, 4))
    x = np.array([r[0] for r in rows])
    for key, label in KEYS:
        ax.plot(x, [r[1]["communication"][key] for r in rows], marker="o", label=label)
    ax.axhline(0.0, color="0.6", lw=0.8)
    ax.set_xlabel("LiDAR noise (share of rays dropped)")
    ax.set_ylabel("value")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(args.out, dpi=110)
    plt.close(fig)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
