"""Readings of a drawn learning curve, so that what a page says about a curve is regenerable:
per trial and metric, where it started, how low it went early in training, the range it kept
afterwards, its level around half the budget and at the end, and its late change
(:func:`training.evaluation.checkpoint_curve.late_change`).

    box2d-driving curve assets/sweeps/curves/communication-12cars-32M.csv --readings
    box2d-driving curve runs/sweep-lights-paper --readings --metric red_light_violation_rate

The windows are shares of a trial's own last checkpoint (:class:`ReadingWindows`), so one
definition reads a 2 M trial and a 32 M one alike. Nothing is evaluated here: the readings come
from the curve file ``box2d-driving curve`` wrote (on selection seeds).
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Collection, Optional

import numpy as np

from training.common.markdown import row
from box2d_driving.metrics.rules import COMMUNICATION
from training.evaluation.checkpoint_curve import CurveError, late_change

__all__ = ["READING_COLUMNS", "ReadingWindows", "SIGN_FREE", "curve_file", "read_curve_file", "readings",
           "readings_table", "summary_of", "summary_rows", "unfinished_trials"]

# metrics whose sign is a convention of the run, not a property of the policy: which bit value
# a speaker uses for "turning" is its own choice, so the curve is read as a magnitude
SIGN_FREE = (COMMUNICATION[1],)


@dataclass(frozen=True)
class ReadingWindows:
    """Where a curve is read, as shares of the trial's last checkpoint's decisions (or of its
    number of checkpoints, for the two averaging windows).

    early: the early low is the lowest value at or before this share of training (the first
        checkpoint's where none is that early).
    settled: the kept range is taken from this share of training on.
    window: each average (around half the budget, at the end) spans this share of the checkpoints.
    """

    early: float = 0.1
    settled: float = 0.15
    window: float = 0.25

    def __post_init__(self) -> None:
        for name in ("early", "settled", "window"):
            value = getattr(self, name)
            if not 0.0 < value <= 1.0:
                raise CurveError(f"ReadingWindows.{name}: {value!r} is not a share in (0, 1]")


# a reading's name -> the table's column heading
READING_COLUMNS = {
    "checkpoints": "checkpoints",
    "first": "first checkpoint",
    "early_low": "low, first {early}",
    "settled_low": "low from {settled}",
    "settled_high": "high from {settled}",
    "half_mean": "mean of {window} of checkpoints ending at half",
    "end_mean": "mean of last {window}",
    "late_change": "late change",
}


def readings(decisions: np.ndarray, values: np.ndarray, windows: ReadingWindows = ReadingWindows()) -> dict[str, float]:
    """The readings of one trial's curve (checkpoints in any order; NaN values are skipped).
    Values in the metric's units; ``checkpoints`` counts the finite ones. A reading whose window
    holds no checkpoint is NaN."""
    d, v = np.asarray(decisions, dtype=float), np.asarray(values, dtype=float)
    order = np.argsort(d, kind="stable")
    d, v = d[order], v[order]
    ok = np.isfinite(v)
    d, v = d[ok], v[ok]
    nan = float("nan")
    if len(d) == 0:
        return {"checkpoints": 0.0, **{k: nan for k in READING_COLUMNS if k != "checkpoints"}}
    last = d[-1]
    width = max(1, int(round(windows.window * len(d))))
    early = v[: max(1, int(np.sum(d <= windows.early * last + 1e-9)))]
    settled = v[d >= windows.settled * last - 1e-9]
    half = v[d <= 0.5 * last + 1e-9][-width:]
    return {
        "checkpoints": float(len(d)),
        "first": float(v[0]),
        "early_low": float(early.min()),
        "settled_low": float(settled.min()),  # never empty: the last checkpoint is in it
        "settled_high": float(settled.max()),
        "half_mean": float(half.mean()) if len(half) else nan,
        "end_mean": float(v[-width:].mean()),
        "late_change": late_change(d, v),
    }


def curve_file(path: Path) -> Path:
    """The curve file of ``path``: the file itself, a sweep folder's ``curves.csv`` or a run
    folder's ``checkpoint_curve/curve.csv``; :class:`CurveError` where none is there."""
    path = Path(path)
    if path.is_file():
        return path
    for candidate in (path / "curves.csv", path / "checkpoint_curve" / "curve.csv"):
        if candidate.is_file():
            return candidate
    raise CurveError(f"{path}: no curve file (a curve CSV, SWEEP/curves.csv or RUN/checkpoint_curve/curve.csv); "
                     "draw one with `box2d-driving curve` first")


def read_curve_file(path: Path) -> tuple[dict[str, list[dict[str, Any]]], list[str]]:
    """Trial name -> its rows of a curve file (a single run's file: one trial named after its
    folder), with the metrics as floats, and the file's metric columns: those after
    ``first_seed``, as :func:`training.evaluation.checkpoint_curve.run_curve` writes them (a
    sweep's grid values come before). :class:`CurveError` for a file that is not a curve."""
    try:
        with open(path, newline="") as f:
            rows = list(csv.DictReader(f))
    except (OSError, UnicodeDecodeError, csv.Error) as exc:
        raise CurveError(f"{path}: cannot read a curve file ({exc})") from None
    header = list(rows[0]) if rows else []
    if "decisions" not in header or "first_seed" not in header:
        raise CurveError(f"{path}: not a curve file (no rows, or no decisions and first_seed columns)")
    metrics = header[header.index("first_seed") + 1:]
    default = path.parent.parent.name if path.parent.name == "checkpoint_curve" else path.stem
    trials: dict[str, list[dict[str, Any]]] = {}
    for i, r in enumerate(rows, start=2):
        parsed: dict[str, Any] = {}
        for k in ("decisions", *metrics):
            value = r.get(k)
            try:
                parsed[k] = float(value) if value not in ("", None) else math.nan
            except ValueError:
                raise CurveError(f"{path}, line {i}: {k}={value!r} is not a number") from None
        trials.setdefault(r.get("trial") or default, []).append(parsed)
    return trials, metrics


def summary_of(path: Path) -> Optional[Path]:
    """The sweep summary that says which trials of the curve file ``path`` have finished:
    ``FOLDER/NAME.json`` for a committed ``FOLDER/curves/NAME.csv``, ``SWEEP/summary.json`` for a
    sweep folder's ``curves.csv``; None where there is none (a single run's curve)."""
    path = Path(path)
    candidates = []
    if path.parent.name == "curves":
        candidates.append(path.parent.parent / f"{path.stem}.json")
    if path.name == "curves.csv":
        candidates.append(path.parent / "summary.json")
    return next((c for c in candidates if c.is_file()), None)


def unfinished_trials(summary: Optional[Path], trials: Collection[str]) -> set[str]:
    """Those of ``trials`` that ``summary`` does not list as done: still training, or stopped
    part-way and carried (a committed summary holds finished trials only), so their curves end
    short of the budget. None without a summary; :class:`CurveError` for a file that is not one."""
    if summary is None:
        return set()
    rows = summary_rows(summary)
    return {t for t in trials if rows.get(t, {}).get("status") != "done"}


def summary_rows(path: Path) -> dict[str, dict[str, Any]]:
    """Trial name -> its row of the sweep summary ``path`` (none where the file does not exist);
    :class:`CurveError` for a file that is not a summary."""
    path = Path(path)
    if not path.exists():
        return {}
    try:
        return {r["trial"]: r for r in json.loads(path.read_text())["trials"]}
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise CurveError(f"{path}: not a sweep summary ({exc})") from None


def readings_table(trials: dict[str, list[dict[str, Any]]], columns: list[str],
                   metrics: Optional[list[str]] = None, windows: ReadingWindows = ReadingWindows(),
                   unfinished: Collection[str] = ()) -> list[str]:
    """A Markdown table of the readings, one row per trial and metric: ``trials`` and its metric
    ``columns`` as :func:`read_curve_file` returns them; ``metrics`` a subset (all by default;
    :class:`CurveError` naming one the file lacks). Shares and bits to two decimals, the late
    change to three; :data:`SIGN_FREE` metrics read as ``|metric|``. The trials in
    ``unfinished`` are marked "(part-way)": their windows are shares of where they stopped."""
    if metrics:
        missing = [m for m in metrics if m not in columns]
        if missing:
            raise CurveError(f"--metric {missing[0]}: not a column of this curve file "
                             f"(its metrics: {', '.join(columns)})")
        columns = list(metrics)
    shares = {k: f"{getattr(windows, k) * 100:g} %" for k in ("early", "settled", "window")}
    heads = ["trial", "metric"] + [h.format(**shares) for h in READING_COLUMNS.values()]
    lines = [row(heads), "|" + "---|" * 2 + "---:|" * len(READING_COLUMNS)]  # numbers right-aligned
    for trial, rows in trials.items():
        d = np.array([r["decisions"] for r in rows])
        for metric in columns:
            v = np.array([r.get(metric, math.nan) for r in rows])
            name = f"|{metric}|" if metric in SIGN_FREE else metric  # row() escapes the bars
            read = readings(d, np.abs(v) if metric in SIGN_FREE else v, windows)
            cells = [f"{int(read['checkpoints'])}"] + [_cell(read[k], k) for k in READING_COLUMNS if k != "checkpoints"]
            label = f"{trial} (part-way)" if trial in unfinished else trial
            lines.append(row([label, name] + cells))
    return lines


def _cell(value: float, reading: str) -> str:
    if not math.isfinite(value):
        return "n/a"
    return f"{value:+.3f}" if reading == "late_change" else f"{value:.2f}"
