"""Compare communication evaluations across LiDAR noise levels (the paper's turn signals): markdown
tables (the metrics, and what each bit value says), whether each measure rises with noise
(Spearman's rho over all runs, with a one-sided permutation p-value) and a plot of speaker
consistency and the heading-change / bit correlations against noise. A noise level may be given
several times (one evaluation per training seed); then a table of means +- std per level follows.

    python training/evaluation/communication_table.py --out docs/images/communication.png \\
        0=runs/comm_n0/eval 0.25=runs/comm_n025/eval 0.5=runs/comm_n05/eval 0.75=runs/comm_n075/eval
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from box2d_driving.metrics.communication import rank_trend
from training.common.cli_args import OneLineParser, error, prog_name
from training.evaluation import plots

KEYS = (("speaker_consistency_bits", "speaker consistency (bits)"),
        ("pearson_heading_change_bit", "Pearson(heading change, bit)"),
        ("pearson_abs_heading_change_bit", "Pearson(|heading change|, bit)"))
# Measures tested for a rise with noise. Which bit value means what is learnt (as which light
# value means stop), so besides the paper's signed correlation the sizes of the correlations are used.
TREND = (("speaker consistency (bits)", lambda c: c["speaker_consistency_bits"]),
         ("Pearson(dh, bit)", lambda c: c["pearson_heading_change_bit"]),
         ("abs Pearson(dh, bit)", lambda c: abs(c["pearson_heading_change_bit"])),
         ("abs Pearson(abs dh, bit)", lambda c: abs(c["pearson_abs_heading_change_bit"])),
         ("abs Pearson(route turn, bit)", lambda c: abs(c["turn_signal"]["pearson_route_turn_bit"])),
         ("MI(movement, bit) (bits)", lambda c: c["turn_signal"]["movement_bit_mi_bits"]))


def training_seed(eval_folder: Path) -> str:
    """The training seed of the checkpoint an evaluation folder sits in, or "-" if unknown."""
    config = eval_folder.parent / "config.json"
    if config.exists():
        return str(json.loads(config.read_text()).get("seed", "-"))
    return "-"


def _all_have(rows: list, value) -> bool:
    """Whether every run's report has the measure (older reports lack the turn-signal ones)."""
    try:
        for r in rows:
            value(r[1]["communication"])
    except KeyError:
        return False
    return True


def main(argv: list[str] | None = None) -> int:
    parser = OneLineParser(prog=prog_name(), description=__doc__.split("\n\n")[0])
    parser.add_argument("runs", nargs="+", help="NOISE=EVAL_FOLDER (with metrics.json)")
    parser.add_argument("--out", required=True, help="plot PNG to write")
    args = parser.parse_args(argv)
    try:
        rows = [_read_run(item) for item in args.runs]
    except _Unreadable as exc:
        return error(str(exc))
    rows.sort(key=lambda r: r[0])
    _print_tables(rows)
    _plot(rows, args.out)
    print(f"wrote {args.out}")
    return 0


class _Unreadable(ValueError):
    """A ``NOISE=EVAL_FOLDER`` argument whose report cannot be compared (the message says why)."""


def _read_run(item: str) -> tuple[float, dict, str]:
    """One ``NOISE=EVAL_FOLDER`` argument: (noise, its report, training seed); :class:`_Unreadable`
    saying what is wrong with it."""
    noise, sep, folder = item.partition("=")
    try:
        level = float(noise)
    except ValueError:
        level = float("nan")
    if not sep or not np.isfinite(level):
        raise _Unreadable(f"{item!r}: expected NOISE=EVAL_FOLDER, e.g. 0.5=runs/comm_n05/eval")
    report = Path(folder) / "metrics.json"
    try:
        m = json.loads(report.read_text())
    except (OSError, ValueError) as exc:
        raise _Unreadable(f"{report}: cannot read the evaluation report ({type(exc).__name__})") from None
    if "communication" not in m:
        raise _Unreadable(f"{folder} was not evaluated with communication")
    if "by_bit" not in m["communication"]:
        raise _Unreadable(f"{folder} predates the per-bit profile; re-evaluate it "
                          "(training/evaluation/evaluate.py --overwrite)")
    return level, m, training_seed(Path(folder))


def _print_tables(rows: list[tuple[float, dict, str]]) -> None:
    """The markdown tables: the measures per run, what each bit value says, the turn-signal
    measures (where every report has them), means per noise level (where a level repeats) and
    whether each measure rises with noise."""
    print("| LiDAR noise | seed | bit = 1 share | speaker consistency (bits) | Pearson(dh, bit) | Pearson(abs dh, bit) "
          "| success | collisions | FIFO share | safe-distance share |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for noise, m, seed in rows:
        c = m["communication"]
        print(f"| {noise} | {seed} | {c['bit_one_share']:.3f} | {c['speaker_consistency_bits']:.4f} | "
              f"{c['pearson_heading_change_bit']:.3f} | {c['pearson_abs_heading_change_bit']:.3f} | "
              f"{m['success_rate']:.3f} | {m['collision_rate']:.3f} | {m['right_of_way']['fifo_share']:.3f} | "
              f"{m['safety_distance']['safe_share']:.3f} |")
    print()
    print("What each value says (sender's means over the decisions it sent it; bit 0 / bit 1):")
    print()
    print("| LiDAR noise | seed | speed (m/s) | next acceleration (m/s²) | abs heading change (rad) |")
    print("|---:|---:|---:|---:|---:|")
    for noise, m, seed in rows:
        b0, b1 = m["communication"]["by_bit"]["0"], m["communication"]["by_bit"]["1"]
        print(f"| {noise} | {seed} | {b0['speed_mean']:.2f} / {b1['speed_mean']:.2f} | "
              f"{b0['next_accel_mean']:.2f} / {b1['next_accel_mean']:.2f} | "
              f"{b0['abs_heading_change_mean']:.3f} / {b1['abs_heading_change_mean']:.3f} |")
    if _all_have(rows, lambda c: c["turn_signal"]):
        print()
        print("Turn signal: the bit against the sender's whole route (cars that arrived; bit = 1 share per movement):")
        print()
        print("| LiDAR noise | seed | Pearson(route turn, bit) | MI(movement, bit) (bits) | right | straight | left |")
        print("|---:|---:|---:|---:|---:|---:|---:|")
        for level, m, seed in rows:
            t = m["communication"]["turn_signal"]
            share = t["bit_one_share_by_movement"]
            print(f"| {level} | {seed} | {t['pearson_route_turn_bit']:.3f} | {t['movement_bit_mi_bits']:.4f} | "
                  f"{share['right']:.3f} | {share['straight']:.3f} | {share['left']:.3f} |")
    trend = [(name, value) for name, value in TREND if _all_have(rows, value)]
    noise_levels = np.array([r[0] for r in rows])
    levels = np.unique(noise_levels)
    if len(levels) < len(rows):
        print()
        print("Per noise level over its runs, mean +- std "
              "(population std, ddof 0: with two runs, half their difference):")
        print()
        print("| LiDAR noise | runs | " + " | ".join(name for name, _ in trend) + " | collisions |")
        print("|---:|---:|" + "---:|" * (len(trend) + 1))
        for level in levels:
            at = [r[1] for r in rows if r[0] == level]
            cells = [[value(m["communication"]) for m in at] for _, value in trend]
            cells.append([m["collision_rate"] for m in at])
            print(f"| {level} | {len(at)} | " + " | ".join(f"{np.mean(v):.3f} +- {np.std(v):.3f}" for v in cells)
                  + " |")
    print()
    print("Does it rise with noise? Spearman's rho over all runs, one-sided permutation p-value:")
    print()
    print("| measure | runs | Spearman rho | p (rises) |")
    print("|---|---:|---:|---:|")
    for name, value in trend:
        t = rank_trend(noise_levels, np.array([value(r[1]["communication"]) for r in rows]))
        print(f"| {name} | {t['n']} | {t['spearman']:.3f} | {t['p_rises']:.3f} |")


def _plot(rows: list[tuple[float, dict, str]], out: str) -> None:
    """Speaker consistency and the heading-change / bit correlations against noise (the mean per
    level, each run as a dot where a level repeats) into ``out``."""
    noise = np.array([r[0] for r in rows])
    levels = np.unique(noise)
    plt = plots._plt()
    fig, ax = plt.subplots(figsize=(6, 4))
    for i, (key, label) in enumerate(KEYS):
        values = np.array([r[1]["communication"][key] for r in rows])
        colour = f"C{i}"
        ax.plot(levels, [values[noise == level].mean() for level in levels], marker="o", color=colour,
                label=label if len(levels) == len(rows) else f"{label} (mean of runs)")
        if len(levels) < len(rows):
            ax.scatter(noise, values, s=14, color=colour, alpha=0.5)
    ax.axhline(0.0, color="0.6", lw=0.8)
    ax.set_xlabel("LiDAR noise (share of rays dropped)")
    ax.set_ylabel("value")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    raise SystemExit(main())
