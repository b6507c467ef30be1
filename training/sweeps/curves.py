"""``box2d-driving curve``: learning curves on selection seeds of a run, or of every trial of a
sweep (:mod:`training.evaluation.checkpoint_curve` draws one run's).

    box2d-driving curve runs/real_junction --episodes 20          # one run: RUN/checkpoint_curve/
    box2d-driving curve runs/sweep-lights-paper --episodes 100    # every trial: OUT/curves.csv
    box2d-driving curve runs/sweep-lanes-paper --finished         # only the trials done so far
    box2d-driving curve assets/sweeps/curves/lanes-paper.csv --readings   # read a drawn curve

A sweep's ``curves.csv`` has one row per kept checkpoint of every trial whose run folder is on
this machine: the trial, its seed and grid values, decisions, agent-steps and the scenario's
curve metrics. ``box2d-driving reproduce --run`` draws them after each flat sweep and keeps them
beside the summary (``assets/sweeps/curves/NAME.csv``), where the results page reads them.
``--readings`` draws nothing: it prints a table of where each trial's drawn curve started,
ranged and ended (:mod:`training.evaluation.curve_readings`).
"""

from __future__ import annotations

import csv
import json
from pathlib import Path
from typing import Any, Callable, Collection, Optional

from training.common.cli_args import error
from training.evaluation.checkpoint_curve import (CurveError, build_parser, checked_out, curve_of_run, draw_into,
                                                  kept_checkpoints, run_curve, write_rows)
from training.evaluation.curve_readings import summary_rows
from training.sweeps.spec import SweepSpec

__all__ = ["SWEEP_CURVE_EPISODES", "curve_of_sweep", "drawn_already", "drawn_decisions", "main", "merge_curves",
           "run_folder", "sweep_curve_rows", "sweep_trials", "trial_curve_rows"]

# selection episodes per checkpoint when ``reproduce --run`` draws a sweep's curves
SWEEP_CURVE_EPISODES = 100


def sweep_trials(sweep: Path) -> list[dict[str, Any]]:
    """Every trial of a sweep folder: its name, seed, grid point, its status in the sweep's summary
    (None before it has a row) and whether that is done, and its run folder (:func:`run_folder`),
    all from one reading of the summary."""
    try:
        spec = SweepSpec(**json.loads((sweep / "sweep.json").read_text()))
    except (OSError, ValueError, TypeError) as exc:
        raise CurveError(f"{sweep}: not a sweep folder ({exc})") from None
    rows = summary_rows(sweep / "summary.json")
    return [{"trial": t["name"], "seed": t["seed"], "point": t["point"],
             "status": rows.get(t["name"], {}).get("status"),
             "done": rows.get(t["name"], {}).get("status") == "done",
             "run": run_folder(sweep, t["name"], rows.get(t["name"]))} for t in spec.trials()]


def run_folder(sweep: Path, name: str, row: Optional[dict[str, Any]]) -> Path:
    """Where trial ``name``'s checkpoints are read. A finished trial, or one stopped part-way: its
    last checkpoint folder in this sweep (``row["run"]``, from the summary). A trial still running:
    the newest checkpoint folder it has reported (``tune/TRIAL/checkpoint_*``, each written once,
    whole, when the trial reports it; the trial trains in its own working directory, which is not
    copied here). A trial with neither: ``tune/TRIAL/run``, the live copy that sweep folders
    written before 2026-12-04 hold (absent from newer ones)."""
    trial = sweep / "tune" / name
    if row and row.get("status") in ("done", "stopped") and row.get("run"):
        final = Path(row["run"])
        if final.parent == trial and (final / "state.json").exists():
            return final
    reported = sorted(c for c in trial.glob("checkpoint_*") if (c / "state.json").exists())
    return reported[-1] if reported else trial / "run"


def sweep_curve_rows(sweep: Path, episodes: int, seed: int, log: Callable[[str], None] = print,
                     finished_only: bool = False) -> list[dict[str, Any]]:
    """The curve rows of every trial of ``sweep`` whose run folder is here (finished or not: a
    running sweep's curves so far; a trial taken from a committed summary has no run folder).
    ``finished_only``: only the trials its summary lists as done, so that a curve judged over the
    last half of training is not drawn from a trial still running."""
    rows = []
    for t in sweep_trials(sweep):
        if finished_only and not t["done"]:
            log(f"{t['trial']}: not finished, skipped")
            continue
        if not t["run"].is_dir():
            log(f"{t['trial']}: no run folder here (not started, or taken from a committed summary), skipped")
            continue
        rows += trial_curve_rows(t, episodes, seed, log)
    return rows


def trial_curve_rows(trial: dict[str, Any], episodes: int, seed: int,
                     log: Callable[[str], None] = print, skip: Collection[int] = ()) -> list[dict[str, Any]]:
    """One trial's curve rows (``trial``: an entry of :func:`sweep_trials`), each headed by the
    trial's name, seed and grid values; checkpoints at the decisions in ``skip`` are not drawn."""
    log(f"{trial['trial']}:")
    return [{"trial": trial["trial"], "seed": trial["seed"], **trial["point"], **row}
            for row in run_curve(trial["run"], episodes, seed, log=lambda line: log("  " + line), skip=skip)]


def _count(row: dict[str, Any], column: str) -> int:
    """A count column of a curve row, read back from CSV text ("3.2e+07" or "32000000") or as drawn."""
    return int(float(row[column]))


def drawn_decisions(path: Path, name: str, episodes: int, seed: int) -> set[int]:
    """The decisions at which the curves file ``path`` holds a row of trial ``name`` drawn on
    ``episodes`` episodes from ``seed`` (rows drawn on other episodes do not count)."""
    if not path.exists():
        return set()
    with open(path, newline="") as f:
        rows = [r for r in csv.DictReader(f) if r.get("trial") == name]
    try:
        return {_count(r, "decisions") for r in rows
                if _count(r, "episodes") == episodes and _count(r, "first_seed") == seed}
    except (KeyError, ValueError):
        return set()


def drawn_already(path: Path, trial: dict[str, Any], episodes: int, seed: int,
                  drawn: Optional[set[int]] = None) -> bool:
    """Whether the curves file ``path`` already holds ``trial``'s curve as its run folder here
    would draw it: a row for every kept checkpoint, on the same episodes (a trial continued to a
    larger budget has more checkpoints, so it is drawn again; rows drawn before the trial was
    carried to this machine count, though their checkpoints stayed behind; a carried run that
    kept no checkpoint since has nothing more to draw). ``drawn``: :func:`drawn_decisions` of
    that file, where the caller has read it already."""
    if drawn is None:
        drawn = drawn_decisions(path, trial["trial"], episodes, seed)
    try:
        kept = {c["decisions"] for c in kept_checkpoints(trial["run"])}
    except CurveError:
        return bool(drawn)
    return kept <= drawn


def merge_curves(path: Path, rows: list[dict[str, Any]]) -> None:
    """Write ``rows`` into the curves file ``path``: a row replaces the row of the same trial at
    the same decisions, every other row is kept (the trials of a continued sweep that ran on
    another machine; a carried trial's rows from before it was carried). Rows stay in training
    order within each trial."""
    mine = {(r["trial"], _count(r, "decisions")) for r in rows}
    kept: list[dict[str, Any]] = []
    if path.exists():
        with open(path, newline="") as f:
            kept = [r for r in csv.DictReader(f) if (r.get("trial"), _count(r, "decisions")) not in mine]
    order = {name: i for i, name in enumerate(dict.fromkeys(r["trial"] for r in kept + rows))}
    merged = sorted(kept + rows, key=lambda r: (order[r["trial"]], _count(r, "decisions")))
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(path.name + ".partial")
    write_rows(tmp, merged)
    tmp.replace(path)


def curve_of_sweep(sweep: Path, out: Path, episodes: int, seed: int, finished_only: bool = False) -> None:
    """The learning curve of every trial of ``sweep`` with checkpoints here (``finished_only``: of
    finished trials only) into ``out/curves.csv``."""
    rows = sweep_curve_rows(sweep, episodes, seed, log=lambda line: print(line, flush=True),
                            finished_only=finished_only)
    if not rows:
        raise CurveError(f"{sweep}: no trial has checkpoints here")
    write_rows(out / "curves.csv", rows)
    print(f"wrote {out / 'curves.csv'}")


def main(argv: Optional[list[str]] = None) -> int:
    parser = build_parser("a run folder (checkpoints/model_<decisions>.safetensors) or a sweep folder "
                          "(sweep.json: every trial's run)")
    parser.add_argument("--finished", action="store_true",
                        help="a sweep: only the trials its summary lists as done (not those still running)")
    parser.add_argument("--readings", action="store_true",
                        help="draw nothing: print a table of readings of the curve already drawn (RUN may then "
                             "also be a curve CSV such as assets/sweeps/curves/NAME.csv)")
    parser.add_argument("--metric", action="append", metavar="NAME",
                        help="with --readings: only this metric (repeatable; default every metric of the file)")
    # None until given, so that --readings can refuse drawing's flags instead of ignoring them
    defaults = {"episodes": parser.get_default("episodes"), "seed": parser.get_default("seed")}
    parser.set_defaults(episodes=None, seed=None)
    args = parser.parse_args(argv)
    if args.readings:
        return print_readings(args)
    for name, value in defaults.items():
        setattr(args, name, value if getattr(args, name) is None else getattr(args, name))
    if args.metric:
        return error("--metric: only with --readings")
    is_sweep = (args.run / "sweep.json").exists()
    if args.finished and not is_sweep:
        return error(f"--finished: {args.run} is not a sweep folder (no sweep.json)")
    out = checked_out(args, "curves.csv" if is_sweep else "curve.csv",
                      args.run if is_sweep else args.run / "checkpoint_curve")
    if is_sweep:
        return draw_into(out, lambda folder: curve_of_sweep(args.run, folder, args.episodes, args.seed,
                                                            finished_only=args.finished))
    return draw_into(out, lambda folder: curve_of_run(args.run, folder, args.episodes, args.seed))


def print_readings(args: Any) -> int:
    """``curve --readings``: the readings table of a drawn curve file; flags that only drawing
    uses are refused rather than ignored."""
    from training.evaluation.curve_readings import (curve_file, read_curve_file, readings_table, summary_of,
                                                    unfinished_trials)

    for flag, given in (("--out", args.out is not None), ("--overwrite", args.overwrite),
                        ("--finished", args.finished), ("--episodes", args.episodes is not None),
                        ("--seed", args.seed is not None)):
        if given:
            return error(f"{flag}: --readings draws nothing (it reads the curve file already drawn)")
    try:
        path = curve_file(args.run)
        trials, columns = read_curve_file(path)
        summary = summary_of(path)
        unfinished = unfinished_trials(summary, trials)
        lines = readings_table(trials, columns, args.metric, unfinished=unfinished)
    except CurveError as exc:
        return error(str(exc))
    print(f"{path} (selection episodes; one row per trial and metric)\n")
    print("\n".join(lines))
    if unfinished:
        print(f"\n(part-way): not done by {summary} (still training, or stopped and carried); its windows "
              "are shares of where it stopped, so its late change is no verdict on the whole budget")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
