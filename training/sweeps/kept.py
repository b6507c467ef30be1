"""Each finished trial's final weights, kept beside its sweep's summary.

So that a metric, a baseline or a second definition can be read from trials already trained
(without training them again), :class:`~training.results.landing.TrialLander` keeps every trial
it lands as a small policy folder:

    SUMMARIES/weights/NAME/<trial>/config.json, model.safetensors            (flat trainers)
    SUMMARIES/weights/NAME/<trial>/accel/..., spline/...                     (bilevel runs)

``model.safetensors`` holds the actor only (its LiDAR encoder, MLP and action head: what acting
needs, about 80,000 float32 values, 0.3 MB; the critic and the optimiser state stay behind), in
the same safetensors format as a run's checkpoint, so ``box2d_driving.policies.load_trained`` and
``box2d-driving evaluate --checkpoint`` read it as they read any policy. Weights are copied
bit for bit: a trial re-evaluated from them acts exactly as it did when its row was written.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

from box2d_driving.policies.checkpoint_file import CheckpointError, read_tensors
from box2d_driving.policies.numpy_actor import ACTOR_PREFIXES

__all__ = ["ACTOR_KEYS", "keep_final_weights", "kept_folder"]

# a checkpoint file's names of what acting reads: the policy tensors (stored under "policy/")
# that box2d_driving.policies.numpy_actor.is_actor_key accepts
ACTOR_KEYS = tuple(f"policy/{prefix}" for prefix in ACTOR_PREFIXES)
STAGES = ("accel", "spline")


def kept_folder(summaries: Path, name: str) -> Path:
    """Where the trials of the sweep ``summaries/NAME.json`` keep their weights."""
    return Path(summaries) / "weights" / name


def _keep_stage(run: Path, dest: Path) -> None:
    from safetensors.numpy import save_file

    path, tensors, meta = read_tensors(run, "numpy")
    actor = {k: v for k, v in tensors.items() if k.startswith(ACTOR_KEYS)}
    if not actor:
        raise CheckpointError(f"{path}: no actor weights to keep")
    dest.mkdir(parents=True, exist_ok=True)
    kept_meta = {k: v for k, v in meta.items() if k in ("format", "version", "counters")}
    save_file(actor, str(dest / "model.safetensors"), metadata=kept_meta)
    if (run / "config.json").exists():  # a bilevel run's spline stage has none of its own
        shutil.copyfile(run / "config.json", dest / "config.json")


def keep_final_weights(run: Path, dest: Path) -> Path:
    """Keep the actor weights and config of the finished run folder ``run`` (a flat run, or a
    bilevel run with ``accel/`` and ``spline/`` stages) in ``dest``, replacing an earlier copy
    whole (written beside it, then renamed); returns ``dest``."""
    run, dest = Path(run), Path(dest)
    tmp = dest.with_name(dest.name + ".partial")
    if tmp.exists():
        shutil.rmtree(tmp)
    stages = [s for s in STAGES if (run / s / "model.safetensors").exists()]
    if stages:
        for stage in stages:
            _keep_stage(run / stage, tmp / stage)
        if (run / "config.json").exists():
            shutil.copyfile(run / "config.json", tmp / "config.json")
    else:
        _keep_stage(run, tmp)
    json.loads((tmp / "config.json").read_text() if (tmp / "config.json").exists()
               else (tmp / stages[0] / "config.json").read_text())  # a readable config
    if dest.exists():
        shutil.rmtree(dest)
    tmp.rename(dest)
    return dest
