"""Where a killed run continues from: the newest complete checkpoint of its folder, wherever it
lies, and logs cut back to it.

A flat run folder keeps its latest checkpoint at the root (``model.safetensors`` + ``state.json``)
and a copy every ``checkpoint_every`` updates in ``checkpoints/``. A kill can land between those
writes (the kept copy written, the root not yet replaced), during one (a ``.partial`` file left),
before the first checkpoint (``config.json`` and logs only), or long after the last one (logs
that run past it). :func:`resume_point` finds the newest checkpoint that reads whole, with the
run's state at it (kept in the checkpoint's metadata; older checkpoints fall back on
``state.json`` when its decisions match); :func:`cut_back` removes what the lost stretch wrote, so
that a resumed run's logs never hold a stretch twice or run backwards.
"""

from __future__ import annotations

import csv
import json
import re
from dataclasses import dataclass
from pathlib import Path
from typing import Optional

from training.runs.checkpoint import FILE, Checkpoint, CheckpointError, read_checkpoint
from training.runs.run_dir import RunError, set_root_checkpoint, write_json_atomic

DECISIONS_COLUMN = "time/total_timesteps"  # SB3's count of decisions at each logged update
_KEPT = re.compile(r"model_(\d+)\.safetensors")
_RESUMED = re.compile(r"(?:progress|config)\.resumed_(\d+)\.(?:csv|json)")

__all__ = ["ResumePoint", "cut_back", "resume_point", "started_files", "truncate_csv"]


@dataclass
class ResumePoint:
    checkpoint: Checkpoint
    decisions: int
    wall_s: float
    agent_steps: int


def _saved_state(out: Path) -> Optional[dict]:
    try:
        state = json.loads((out / "state.json").read_text()[:100_000])
        return {"decisions": int(state["decisions"]), "wall_s": float(state["wall_s"]),
                "agent_steps": int(state["agent_steps"])}
    except (OSError, ValueError, KeyError, TypeError, OverflowError):
        return None


def _candidates(out: Path) -> list[Path]:
    """Root first, then the kept copies newest first (by the decisions in their names)."""
    kept = []
    for path in (out / "checkpoints").glob("model_*.safetensors"):
        match = _KEPT.fullmatch(path.name)
        if match:
            kept.append((int(match.group(1)), path))
    return [out / FILE] + [path for _, path in sorted(kept, reverse=True)]


def resume_point(out: Path) -> Optional[ResumePoint]:
    """The newest checkpoint in ``out`` that reads whole and whose run state is known; None when
    there is none (a run killed before its first checkpoint). Unreadable files are passed over;
    :class:`RunError` when the only readable ones have no known state."""
    state = _saved_state(out)
    best: Optional[ResumePoint] = None
    stateless: Optional[Path] = None
    for path in _candidates(out):
        if not path.is_file():
            continue
        if best is not None and path != out / FILE:
            match = _KEPT.fullmatch(path.name)
            if match and int(match.group(1)) <= best.decisions:
                break  # the rest are older than what we have
        try:
            ckpt = read_checkpoint(path)
        except CheckpointError:
            continue
        decisions = ckpt.counters.get("num_timesteps", 0)
        if ckpt.optimizer is None or (best is not None and decisions <= best.decisions):
            continue
        run_state = ckpt.run_state
        if run_state is None and state is not None and state["decisions"] == decisions:
            run_state = state  # a checkpoint from before run states were kept in the file
        if run_state is None:
            stateless = stateless or path
            continue
        best = ResumePoint(ckpt, decisions, run_state["wall_s"], int(run_state["agent_steps"]))
    if best is None and stateless is not None:
        raise RunError(f"--resume: {out / 'state.json'} is missing or is not {stateless.name}'s (a checkpoint "
                       f"written before the run's state was kept in it needs the state.json saved with it)")
    return best


def started_files(out: Path) -> list[Path]:
    """What a run killed before its first checkpoint left besides ``config.json``: its logs, and
    the partial files of an interrupted first write."""
    names = ["progress.csv", "state.json", FILE + ".partial"]
    found = [out / n for n in names if (out / n).exists()]
    found += sorted(out.glob("events.out.tfevents.*"))  # TensorBoard's logs
    found += sorted(p for p in out.iterdir() if _RESUMED.fullmatch(p.name))
    found += sorted((out / "checkpoints").glob("*")) if (out / "checkpoints").is_dir() else []
    return found


def cut_back(out: Path, point: ResumePoint) -> list[str]:
    """Make ``out`` read as if the run had stopped at ``point``: CSV rows past its decisions
    removed, logs and configs of legs that started past it removed, partial files removed, and the
    root checkpoint and ``state.json`` made its. Returns what was cut, for the message."""
    cut: list[str] = []
    for path in sorted(out.glob("*.partial")) + sorted((out / "checkpoints").glob("*.partial")):
        path.unlink()
        cut.append(path.name)
    for path in sorted(out.iterdir()):
        match = _RESUMED.fullmatch(path.name)
        if match and int(match.group(1)) > point.decisions:
            path.unlink()
            cut.append(path.name)
    for log in [out / "progress.csv"] + sorted(out.glob("progress.resumed_*.csv")):
        dropped = truncate_csv(log, DECISIONS_COLUMN, point.decisions)
        if dropped:
            cut.append(f"{dropped} rows of {log.name}")
    if point.checkpoint.path != out / FILE:
        set_root_checkpoint(out, point.checkpoint.path, point.decisions, point.agent_steps, point.wall_s)
        cut.append(f"{FILE} replaced by {point.checkpoint.path.relative_to(out)}")
    else:
        write_json_atomic(out / "state.json", {"decisions": point.decisions, "agent_steps": point.agent_steps,
                                               "wall_s": point.wall_s})
    return cut


def truncate_csv(path: Path, column: str, upto: float) -> int:
    """Keep the rows of CSV ``path`` whose ``column`` is at most ``upto`` (rewritten whole); the
    number of rows removed."""
    if not path.is_file():
        return 0
    with path.open(newline="") as fh:
        rows = list(csv.reader(fh))
    if not rows or column not in rows[0]:
        return 0
    col = rows[0].index(column)

    def keep(row: list[str]) -> bool:
        try:
            return float(row[col]) <= upto
        except (IndexError, ValueError):
            return False  # a row cut short by the kill

    kept = [rows[0]] + [row for row in rows[1:] if keep(row)]
    if len(kept) == len(rows):
        return 0
    tmp = path.with_name(path.name + ".partial")
    with tmp.open("w", newline="") as fh:
        csv.writer(fh).writerows(kept)
    tmp.replace(path)
    return len(rows) - len(kept)
