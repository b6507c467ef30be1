"""Run folders, shared by the flat trainer (``training/trainers/trainer.py``) and the bilevel trainer
(``training/trainers/bilevel.py``): checks before a run starts or resumes, configs and state written whole,
and the logs a resumed leg appends.

A new run writes nothing until every check has passed (the caller creates the folder once its
model is built); ``config.json`` is the first leg's, each ``--resume`` records its own
``config.resumed_<decisions>.json``; ``state.json`` and checkpoints are replaced whole.
"""

from __future__ import annotations

import dataclasses
import errno
import json
import shutil
from pathlib import Path
from typing import Any, Iterable

from training.runs.checkpoint import FILE, LEGACY_FILE, legacy_message


LOCK_FILE = ".lock"  # held by the process training in the folder (training/runs/lock.py)


class RunError(RuntimeError):
    """A run folder cannot be used as asked (exists, missing, incompatible)."""


def check_new(out: Path) -> None:
    """A new run needs ``out`` absent or empty; nothing is overwritten silently."""
    if out.exists() and any(p.name != LOCK_FILE for p in out.iterdir()):
        raise RunError(f"{out} exists and is not empty; choose another --out or pass --resume")


def check_resumable(out: Path, needed: Iterable[str]) -> None:
    """Every file in ``needed`` (relative to ``out``) exists; a pickled ``model.zip`` where a
    ``model.safetensors`` is needed gets the converter's name."""
    for need in needed:
        if (out / need).exists():
            continue
        legacy = out / need.replace(FILE, LEGACY_FILE)
        if legacy != out / need and legacy.exists():
            raise RunError(f"--resume: {legacy_message(legacy)}")
        raise RunError(f"--resume: {out / need} is missing (a run folder needs {', '.join(needed)})")


def check_same_run(saved: dict, config: Any) -> None:
    """Refuse to resume a run (its saved TrainConfig as a dict) under another env or critic. The
    env's overrides are compared as the configs they make, so a setting added after the run
    started, now given at the value the run had by default, does not block it."""
    for key in ("env_id", "env_overrides", "critic"):
        now = json.loads(json.dumps(getattr(config, key)))
        if saved.get(key) == now:
            continue
        if key == "env_overrides" and saved.get("env_id") == config.env_id \
                and (before := _env_config(config.env_id, saved.get(key) or {})) is not None \
                and before == _env_config(config.env_id, now):
            continue
        raise RunError(f"--resume: {key} differs from the checkpoint's "
                       f"({saved.get(key)!r} vs {getattr(config, key)!r})")


def _env_config(env_id: str, overrides: dict) -> Any:
    """The full env config ``overrides`` make for ``env_id``, as JSON values; None if they make
    none (an unknown field, a refused value)."""
    from box2d_driving.scenarios import scenario

    try:
        config = getattr(scenario(env_id).env_class, "config_class")(**overrides)
    except (TypeError, ValueError, KeyError):
        return None
    return json.loads(json.dumps(dataclasses.asdict(config)))


def write_json_atomic(path: Path, data: Any) -> None:
    """``data`` as JSON, replacing ``path`` whole (written beside it, then renamed; a failed write
    removes its partial file and leaves ``path`` as it was)."""
    tmp = path.with_name(path.name + ".partial")
    try:
        tmp.write_text(json.dumps(data, indent=2))
        tmp.replace(path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def set_root_checkpoint(out: Path, kept: Path, decisions: int, agent_steps: int, wall_s: float) -> None:
    """Make the kept checkpoint file ``kept`` the run's latest: copied to ``OUT/model.safetensors``
    (beside it, then renamed; a failed copy leaves the old one and no partial file), then
    ``state.json`` written with the run's counters at it."""
    tmp = out / (FILE + ".partial")
    try:
        shutil.copyfile(kept, tmp)
        tmp.replace(out / FILE)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    write_json_atomic(out / "state.json", {"decisions": decisions, "agent_steps": agent_steps, "wall_s": wall_s})


# what a full, read-only, over-quota or failing disk raises while a run writes
STORAGE_ERRNOS = frozenset(getattr(errno, name) for name in
                           ("ENOSPC", "EDQUOT", "EFBIG", "EROFS", "EIO", "EACCES", "EPERM", "ENOTDIR")
                           if hasattr(errno, name))


def storage_error(out: Path, exc: OSError) -> RunError:
    """The one-line error for a write into run folder ``out`` that the disk refused."""
    what = f"writing {exc.filename}" if exc.filename else "writing"
    return RunError(f"{what} failed ({exc.strerror or exc}); the run in {out} stopped, and its last "
                    f"complete checkpoint is kept: make room, then continue it with --resume")


def write_config(path: Path, config: Any, algorithm: str) -> None:
    """A config dataclass as JSON (``config.json``, ``config.resumed_*.json``), with the name of
    the algorithm that trains it (``"algorithm"``: how the loaders read the run folder)."""
    write_json_atomic(path, {"algorithm": algorithm, **dataclasses.asdict(config)})


def append_logger(out: Path, decisions: int):
    """On resume, log to a new CSV named after the decision it resumes from (earlier logs are
    kept) and to the same TensorBoard folder."""
    from stable_baselines3.common.logger import CSVOutputFormat, Logger, TensorBoardOutputFormat

    csv = CSVOutputFormat(str(out / f"progress.resumed_{decisions:012d}.csv"))
    return Logger(str(out), [csv, TensorBoardOutputFormat(str(out))])
