"""``box2d-driving reproduce --reevaluate``: a sweep's report metrics measured again from the
weights its trials kept, without training them again.

Every trial a sweep lands keeps its final actor (:mod:`training.sweeps.kept`:
``SUMMARIES/weights/NAME/<trial>/``). Re-evaluating runs that actor on the very report episodes
its summary row was measured on (the row's ``report_first_seed`` and ``report_episodes``) with
today's metric code, and replaces the row's report columns (and the figures' counts) with what
it measures. The training columns (budget, wall time, seed, grid point) stay. So a metric, a
second definition or a figure added to the evaluation after a sweep ran reaches its trials; and
where nothing changed in the code, the row comes back exactly as it was (episodes are seeded and
the policy acts deterministically).

Trials that kept no weights (landed before weights were kept) keep their rows as they were and
are listed; the page says how many of each summary's trials can be re-evaluated.
"""

from __future__ import annotations

import json
import math
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

from training.results.data import ResultsError

__all__ = ["ReevaluateResult", "kept_count", "reevaluate_summary", "report_columns_of"]

# report columns that measure the evaluation itself, not the policy: never counted as a change
NOT_MEASURES = ("eval_seconds",)


@dataclass
class ReevaluateResult:
    """What re-evaluating one summary did."""

    name: str
    reevaluated: list[str] = field(default_factory=list)  # trials measured again
    not_kept: list[str] = field(default_factory=list)  # finished trials without kept weights
    changed: dict[str, list[str]] = field(default_factory=dict)  # trial -> columns whose value changed
    added: dict[str, list[str]] = field(default_factory=dict)  # trial -> columns it did not have
    removed: dict[str, list[str]] = field(default_factory=dict)  # trial -> columns no longer measured

    def lines(self) -> list[str]:
        named = self.not_kept if len(self.not_kept) <= 4 else \
            self.not_kept[:3] + [f"and {len(self.not_kept) - 3} more"]
        out = [f"{self.name}: {len(self.reevaluated)} trials re-evaluated, {len(self.not_kept)} kept no weights"
               + (f" ({', '.join(named)})" if self.not_kept else "")]
        for trial in self.reevaluated:
            parts = [f"{word} {', '.join(cols)}" for word, cols in (
                ("changed", self.changed.get(trial)), ("new", self.added.get(trial)),
                ("no longer measured", self.removed.get(trial))) if cols]
            if parts:
                out.append(f"  {trial}: " + "; ".join(parts))
            else:
                out.append(f"  {trial}: every report column as it was")
        return out


def _fixed_columns(grid: dict[str, Any]) -> set[str]:
    """The columns of a row that say which trial it is and how it trained (kept as they are)."""
    from training.sweeps.summary import SUMMARY_FIXED

    return set(SUMMARY_FIXED) | set(grid)


def report_columns_of(row: dict[str, Any], grid: dict[str, Any]) -> dict[str, Any]:
    """A summary row's report columns (what its evaluation measured; the figures' counts aside)."""
    fixed = _fixed_columns(grid) | {"figures"}
    return {k: v for k, v in row.items() if k not in fixed}


def _same(a: Any, b: Any) -> bool:
    """Equal as measured values: numbers by value (an int count and its float equal), NaN equal to
    NaN, a boolean only to a boolean."""
    if isinstance(a, bool) or isinstance(b, bool):
        return a is b
    if isinstance(a, (int, float)) and isinstance(b, (int, float)):
        return a == b or (math.isnan(a) and math.isnan(b))
    return a == b


def kept_count(summary_path: Path, trials: list[dict[str, Any]]) -> tuple[int, int]:
    """(finished trials whose final weights are kept beside the summary, finished trials)."""
    from training.sweeps.kept import kept_folder

    folder = kept_folder(Path(summary_path).parent, Path(summary_path).stem)
    done = [r["trial"] for r in trials if r.get("status") == "done"]
    return sum(_is_kept(folder / t) for t in done), len(done)


def _is_kept(folder: Path) -> bool:
    return (folder / "model.safetensors").is_file() or (folder / "accel" / "model.safetensors").is_file()


def _measure(kept: Path, row: dict[str, Any]) -> dict[str, Any]:
    """The kept policy on the row's report episodes: the row's report columns as they are now."""
    from training.evaluation.evaluate import Args, evaluate
    from training.sweeps.summary import report_metrics, summary_row

    with tempfile.TemporaryDirectory(prefix="reevaluate-") as tmp:
        out = Path(tmp) / "eval"
        metrics = evaluate(Args(checkpoint=str(kept), episodes=int(row["report_episodes"]),
                                seed=int(row["report_first_seed"]), out=str(out)))
        reported = report_metrics(metrics, out / "rollouts.npz", kept)
    # the columns a sweep writes from the same metrics (summary_row); the caller keeps the row's fixed ones
    return summary_row({"name": row["trial"], "behaviour": row.get("behaviour", ""), "seed": row.get("seed"),
                        "point": {}}, "done", reported)


def reevaluate_summary(summary_path: Path, log: Callable[[str], None] = print,
                       measure: Callable[[Path, dict[str, Any]], dict[str, Any]] = _measure) -> ReevaluateResult:
    """Re-evaluate every finished trial of the summary ``summary_path`` (``NAME.json``) that kept
    its weights, and rewrite ``NAME.json`` and ``NAME.csv`` with the measured report columns
    (only after every trial was measured: an error leaves both files as they were). Raises
    :class:`ResultsError` naming the summary or the trial's weights when one cannot be read."""
    from box2d_driving.policies.checkpoint_file import CheckpointError
    from training.sweeps.kept import kept_folder
    from training.sweeps.summary import write_summary_files

    path = Path(summary_path)
    try:
        saved = json.loads(path.read_text())
        sweep, trials, grid = saved["sweep"], list(saved["trials"]), dict(saved["sweep"]["grid"])
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise ResultsError(f"{path}: not a sweep summary ({exc})") from None
    weights = kept_folder(path.parent, path.stem)
    result = ReevaluateResult(path.stem)
    rows = []
    for row in trials:
        if row.get("status") != "done":
            rows.append(row)
            continue
        kept = weights / str(row["trial"])
        if not _is_kept(kept):
            result.not_kept.append(row["trial"])
            rows.append(row)
            continue
        log(f"{path.stem}: re-evaluating {row['trial']} on {row['report_episodes']} report episodes "
            f"from seed {row['report_first_seed']:,}")
        try:
            fresh = measure(kept, row)
        except (CheckpointError, OSError, ValueError, KeyError) as exc:
            raise ResultsError(f"{kept}: the kept weights of trial {row['trial']} could not be re-evaluated "
                               f"({exc}); {path.name} is unchanged") from None
        fixed = _fixed_columns(grid)
        old = report_columns_of(row, grid)
        new_columns = {k: v for k, v in fresh.items() if k not in fixed and k != "figures"}
        changed = [k for k in new_columns if k in old and k not in NOT_MEASURES and not _same(old[k], new_columns[k])]
        if json.dumps(row.get("figures"), sort_keys=True) != json.dumps(fresh.get("figures"), sort_keys=True):
            changed.append("figures")
        added = [k for k in new_columns if k not in old]
        if changed:
            result.changed[row["trial"]] = changed
        if added:
            result.added[row["trial"]] = added
        removed = [k for k in old if k not in new_columns]
        if removed:
            result.removed[row["trial"]] = removed
        # the row's columns in their order, report ones measured again (one no longer measured goes)
        updated = {k: (new_columns[k] if k in new_columns else v) for k, v in row.items()
                   if k in fixed or k in new_columns}
        updated.update({k: new_columns[k] for k in added})
        if fresh.get("figures"):
            updated["figures"] = fresh["figures"]
        rows.append(updated)
        result.reevaluated.append(row["trial"])
    if result.reevaluated:
        write_summary_files(path.parent, path.stem, sweep, rows)
    return result
