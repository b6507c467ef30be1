"""A sweep's results: what trials report to Ray Tune, and the summary table (CSV and JSON, one
row per trial) written from them."""

from __future__ import annotations

import csv
import dataclasses
import json
import math
from pathlib import Path
from typing import Any

from training.runs.run_dir import write_json_atomic
from training.sweeps.spec import SweepError, SweepSpec, extension_differences, spec_differences

SUMMARY_FIXED = ("trial", "behaviour", "seed", "status", "error", "decisions", "agent_steps",
                 "wall_s", "report_episodes", "report_first_seed", "run")
def train_metrics(progress: dict[str, Any]) -> dict[str, Any]:
    """A checkpoint's training statistics under ``train/`` (flat and bilevel runs alike)."""
    if "accel_success" in progress:  # a bilevel round
        return {"success_rate": progress["accel_success"], "train/success_rate": progress["accel_success"],
                "train/collision_rate": progress["accel_collision"],
                "train/round": progress["round"], "train/agent_steps": progress["agent_steps"],
                "train/wall_s": progress["wall_s"], "done": 0}
    keep = {"rollout/success_rate": "success_rate", "rollout/collision_rate": "collision_rate",
            "rollout/red_light_violation_rate": "red_light_violation_rate", "time/decisions": "decisions",
            "time/agent_steps": "agent_steps", "time/wall_s": "wall_s"}
    out = {f"train/{short}": progress[k] for k, short in keep.items() if k in progress}
    return {**out, "success_rate": out.get("train/success_rate", math.nan), "done": 0}


def final_metrics(run: Path, metrics: dict[str, Any]) -> dict[str, Any]:
    """The report-seed evaluation, flattened to ``report/<name>`` scalars, with the run's counters
    and the distributions a results page draws (``figures``, from the evaluation's rollouts)."""
    state = json.loads((run / "state.json").read_text())
    out = report_metrics(metrics, run / "eval" / "rollouts.npz", run)
    out.update({"train/decisions": state.get("decisions", state.get("accel_decisions")),
                "train/agent_steps": state["agent_steps"], "train/wall_s": state["wall_s"], "done": 1})
    return out


def report_metrics(metrics: dict[str, Any], rollouts: Path, policy: Path) -> dict[str, Any]:
    """An evaluation's ``metrics.json`` as the report columns a summary row holds: ``report/<name>``
    scalars, the episodes it ran, and ``figures`` drawn from its ``rollouts`` table (with the env of
    the policy folder ``policy``: a run folder, or a trial's kept weights)."""
    out = {f"report/{k}": v for k, v in flatten(metrics).items()
           if k not in ("seed", "episodes", "checkpoint") and not k.startswith(("training.", "trained_on."))}
    out.update({"report_episodes": metrics["episodes"], "report_first_seed": metrics["seed"],
                "success_rate": metrics.get("success_rate", math.nan)})
    if Path(rollouts).exists():
        from box2d_driving.metrics.rollouts import load_table
        from training.evaluation.figure_data import figure_data
        from training.runs.inference import load_policy

        env = load_policy(policy).make_env()
        out["figures"] = figure_data(metrics["env_id"], load_table(rollouts), env.config)
        env.close()
    return out


def flatten(d: dict[str, Any], prefix: str = "") -> dict[str, Any]:
    """Nested metrics as ``a.b`` keys; numbers, booleans and strings only (lists are left out)."""
    out: dict[str, Any] = {}
    for k, v in d.items():
        key = f"{prefix}{k}"
        if isinstance(v, dict):
            out.update(flatten(v, key + "."))
        elif isinstance(v, (bool, int, float, str)) or v is None:
            out[key] = v
    return out

def metrics_from_row(row: dict[str, Any]) -> dict[str, Any]:
    """A finished trial's summary row as the metrics its trial reported (for ``--reuse``)."""
    fixed = set(SUMMARY_FIXED) | set(row.get("grid_keys", ())) | {"grid_keys", "figures"}
    out = {f"report/{k}": v for k, v in row.items() if k not in fixed}
    if row.get("figures"):
        out["figures"] = row["figures"]
    out.update({"train/decisions": row["decisions"], "train/agent_steps": row["agent_steps"],
                "train/wall_s": row["wall_s"], "report_episodes": row["report_episodes"],
                "report_first_seed": row["report_first_seed"], "run": row["run"],
                "success_rate": row.get("success_rate", math.nan), "done": 1})
    return out


def reusable_rows(path: Path, spec: SweepSpec) -> dict[str, dict[str, Any]]:
    """The finished trials of a summary written by this same sweep (e.g. committed from an
    earlier machine), by trial name; :class:`SweepError` if it is another sweep's. Only the
    number of training seeds may differ: seed ``s`` of the same settings is the same trial in a
    sweep of 3 seeds or of 5, so adding seeds trains only the new ones (and fewer seeds keep the
    first ones)."""
    try:
        saved = json.loads(Path(path).read_text())
        old, rows = saved["sweep"], saved["trials"]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise SweepError(f"--reuse {path}: not a sweep summary ({exc})") from None
    diff = [k for k in spec_differences(old, spec) if k != "seeds"]
    if diff:
        raise SweepError(f"--reuse {path}: another sweep's summary ({', '.join(diff)} differ)")
    return {r["trial"]: {**r, "grid_keys": list(spec.grid)} for r in rows
            if r.get("status") == "done" and isinstance(r.get("seed"), int) and 0 <= r["seed"] < spec.seeds}


def extendable_runs(old_out: Path, spec: SweepSpec) -> dict[str, Path]:
    """The finished trials of the sweep folder ``old_out`` that ``spec`` (the same sweep at a larger
    budget) continues, by trial name: each trial's run folder (its last checkpoint: a complete run
    folder), where it is on this machine. :class:`SweepError` if ``old_out`` is not a sweep folder
    or ``spec`` cannot extend it (naming what differs)."""
    try:
        saved = json.loads((Path(old_out) / "sweep.json").read_text())
        rows = json.loads((Path(old_out) / "summary.json").read_text())["trials"]
    except (OSError, ValueError, KeyError, TypeError) as exc:
        raise SweepError(f"--extend {old_out}: not a sweep folder with a summary ({exc})") from None
    diff = extension_differences(saved, spec)
    if diff:
        raise SweepError(f"--extend {old_out}: this sweep cannot continue its trials ({'; '.join(diff)})")
    return {r["trial"]: Path(r["run"]) for r in rows
            if r.get("status") == "done" and r.get("run") and (Path(r["run"]) / "state.json").exists()}


def unreached_row(trial: dict[str, Any]) -> dict[str, Any]:
    """The summary row of a trial a sweep stopped before reaching: the row an earlier run of the
    sweep measured (``--reuse``; ``reproduce --run`` continues every committed summary so), as it
    was, else ``pending``. A stop must not turn a finished trial back into a missing one."""
    earlier = trial.get("reuse")
    if earlier:
        return {k: v for k, v in earlier.items() if k != "grid_keys"}
    return summary_row(trial, "pending", {})


def summary_row(trial: dict[str, Any], status: str, metrics: dict[str, Any], error: str = "",
                run: str = "") -> dict[str, Any]:
    """One trial's row of the sweep summary: its name, seed, status and grid point, the training
    budget it ran and every report metric (figures' counts nested under ``figures``)."""
    row = {"trial": trial["name"], "behaviour": trial["behaviour"], "seed": trial["seed"],
           "status": status, "error": error, "run": run or metrics.get("run", ""),
           "decisions": metrics.get("train/decisions"), "agent_steps": metrics.get("train/agent_steps"),
           "wall_s": metrics.get("train/wall_s"), "report_episodes": metrics.get("report_episodes"),
           "report_first_seed": metrics.get("report_first_seed")}
    row.update(trial["point"])
    row.update({k[len("report/"):]: v for k, v in metrics.items() if k.startswith("report/")})
    figures = dict(metrics.get("figures") or {})  # nested as reported, or flattened by Ray
    figures.update({k[len("figures/"):]: v for k, v in metrics.items() if k.startswith("figures/")})
    if figures:
        row["figures"] = figures
    return row


def write_summary(out: Path, spec: SweepSpec, rows: list[dict[str, Any]]) -> None:
    """``summary.json`` (settings and rows) and ``summary.csv`` (rows), each replaced whole."""
    write_summary_files(out, "summary", dataclasses.asdict(spec), rows)


def write_summary_files(folder: Path, stem: str, sweep: dict[str, Any], rows: list[dict[str, Any]]) -> None:
    """``folder/STEM.json`` (the sweep's settings ``sweep``, as :class:`SweepSpec` fields, and the
    rows) and ``folder/STEM.csv`` (the rows, the figures' counts left out), each replaced whole."""
    rows = sorted(rows, key=lambda r: r["trial"])
    write_json_atomic(folder / f"{stem}.json", {"sweep": sweep, "trials": rows})
    columns = list(SUMMARY_FIXED[:3]) + list(sweep["grid"]) + list(SUMMARY_FIXED[3:])
    for row in rows:  # the figures' counts stay in the JSON
        columns += [k for k in row if k not in columns and k != "figures"]
    tmp = folder / f"{stem}.csv.partial"
    with tmp.open("w", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=columns, extrasaction="ignore")
        writer.writeheader()
        writer.writerows(rows)
    tmp.replace(folder / f"{stem}.csv")

def first_line(text: object) -> str:
    lines = [ln for ln in str(text).strip().splitlines() if ln.strip()]
    return lines[-1][:300] if lines else ""
