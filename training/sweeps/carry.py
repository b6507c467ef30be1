"""Trials stopped part-way, carried to another machine.

A sweep folder continues an interrupted trial from its last checkpoint, but only on the machine
that holds it. When the machine itself goes away (a lent node, a session's machine), the trial
can travel as a *carried run*: its run folder less what is only needed to look back (the kept
checkpoints, the TensorBoard logs), i.e. its latest checkpoint with optimiser state, its config,
counters and progress logs, a few MB. A sweep given a folder of carried runs (``sweep
--carried DIR``, or ``reproduce --run``, which carries its stopped trials into the summaries
folder itself) continues each of those trials from there instead of starting it over.

    CARRIED/<trial name>/config.json, state.json, model.safetensors, progress*.csv, ...

The learning curve of the part trained before the carry cannot be drawn from the carried run
(its checkpoints stay behind), so whoever carries a trial draws those rows first
(:meth:`training.results.landing.TrialLander.carry`).
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path
from typing import Any, Optional

from training.runs.run_dir import LOCK_FILE
from training.sweeps.spec import SweepError, SweepSpec

__all__ = ["LEFT_BEHIND", "carried_folder", "carried_runs", "carried_trials", "carry_run"]

# what a carried run leaves behind: the kept checkpoints (at any depth: a bilevel run's stages
# have their own), TensorBoard logs, an evaluation (a carried trial has not finished), and the
# lock of the process that trained there (it names that machine's process; the next one makes its own)
LEFT_BEHIND = ("checkpoints", "tb", "eval", "events.out.tfevents.*", LOCK_FILE)


def carried_folder(summaries: Path, name: str) -> Path:
    """Where ``reproduce --run`` keeps the carried runs of the sweep whose summary is
    ``summaries/NAME.json``: ``summaries/carried/NAME/``."""
    return Path(summaries) / "carried" / name


def carry_run(run: Path, dest: Path) -> Path:
    """Copy the resumable part of the run folder ``run`` to ``dest`` (replacing an older carry of
    the same trial whole: written beside it, then renamed); returns ``dest``."""
    run, dest = Path(run), Path(dest)
    if not (run / "state.json").exists() or not (run / "config.json").exists():
        raise SweepError(f"{run}: not a run folder to carry (config.json and state.json needed)")
    tmp = dest.with_name(dest.name + ".partial")
    if tmp.exists():
        shutil.rmtree(tmp)
    dest.parent.mkdir(parents=True, exist_ok=True)
    shutil.copytree(run, tmp, ignore=shutil.ignore_patterns(*LEFT_BEHIND))
    if dest.exists():
        shutil.rmtree(dest)
    tmp.rename(dest)
    return dest


def carried_trials(folder: Path) -> list[Path]:
    """The carried run folders in ``folder`` (one per trial, by name), less a carry still being
    written (``carry_run``'s ``.partial``)."""
    return sorted(p for p in Path(folder).iterdir() if p.is_dir() and not p.name.endswith(".partial"))


def _saved_seed(config: dict[str, Any]) -> Optional[int]:
    """The training seed a run's config.json holds (a bilevel run keeps it at the top or per stage)."""
    if "seed" in config:
        return int(config["seed"])
    for stage in ("accel", "spline"):
        if isinstance(config.get(stage), dict) and "seed" in config[stage]:
            return int(config[stage]["seed"])
    return None


def carried_runs(folder: Optional[Path], spec: SweepSpec) -> dict[str, Path]:
    """The carried runs in ``folder`` by trial name (none where it does not exist).
    :class:`SweepError` names a folder in it that is not a trial of ``spec``, not a run folder,
    or a run of another training seed."""
    if folder is None or not Path(folder).is_dir():
        return {}
    trials = {t["name"]: t for t in spec.trials()}
    found = {}
    for run in carried_trials(Path(folder)):
        if run.name not in trials:
            raise SweepError(f"--carried {folder}: {run.name} is not a trial of this sweep")
        try:
            config = json.loads((run / "config.json").read_text())
            json.loads((run / "state.json").read_text())
        except (OSError, ValueError) as exc:
            raise SweepError(f"--carried {run}: not a run folder ({exc})") from None
        seed = _saved_seed(config) if isinstance(config, dict) else None
        if seed != trials[run.name]["seed"]:
            raise SweepError(f"--carried {run}: trained with seed {seed}, the trial's seed is "
                             f"{trials[run.name]['seed']}")
        found[run.name] = run
    return found
