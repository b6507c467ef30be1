"""Checkpoints that cannot run code when they are read: the trainer's side (torch tensors,
optimiser state, writing). The file format, its safety checks and :class:`CheckpointError` live in
:mod:`box2d_driving.policies.checkpoint_file`, which runs policies without torch; this module
reads the same files into torch and writes them.

An older ``model.zip`` of the user's own can be converted once with
``box2d-driving convert-checkpoint RUN --trust-pickle`` (which unpickles it: see that command).
"""

from __future__ import annotations

import contextlib
import json
import math
import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Optional, Union

import torch as th

from box2d_driving.policies.checkpoint_file import (FILE, FORMAT, LEGACY_FILE, VERSION,  # noqa: F401
                                                    CheckpointError, find_checkpoint, legacy_message,
                                                    read_tensors)


@dataclass
class Checkpoint:
    """What a ``model.safetensors`` holds: policy weights, optional optimiser state, counters."""

    path: Path
    policy: dict[str, th.Tensor]
    optimizer: Optional[dict[str, Any]]  # an ``optimizer.state_dict()``, or None
    counters: dict[str, int]
    run_state: Optional[dict[str, float]] = None  # ``wall_s``, ``agent_steps`` where saved (see save_model)


def _tensor_bytes(t: th.Tensor) -> th.Tensor:
    # safetensors refuses tensors that share storage or are not contiguous: give each its own copy
    return t.detach().to("cpu").contiguous().clone()


def save_model(model: Any, path: Union[str, Path], *, with_optimizer: bool = True,
               run_state: Optional[dict[str, float]] = None) -> Path:
    """Write ``model`` (an SB3 ``PPO``) to ``path`` atomically: a reader sees the old file or the
    whole new one, never half of it. ``run_state`` (the run's ``wall_s`` and ``agent_steps`` at
    this checkpoint) goes in the metadata, so that any kept checkpoint can be resumed from alone.

    The bytes are made in memory and written by Python, so that a full disk or a read-only folder
    is an ``OSError`` naming the file (which the trainers turn into one line)."""
    from safetensors.torch import save

    path = Path(path)
    tensors = {f"policy/{k}": _tensor_bytes(v) for k, v in model.policy.state_dict().items()}
    meta = {"format": FORMAT, "version": str(VERSION),
            "counters": json.dumps({"num_timesteps": int(model.num_timesteps),
                                    "n_updates": int(getattr(model, "_n_updates", 0))})}
    if run_state is not None:
        meta["run_state"] = json.dumps({"wall_s": float(run_state["wall_s"]),
                                        "agent_steps": int(run_state["agent_steps"])})
    if with_optimizer:
        state = model.policy.optimizer.state_dict()
        for idx, entries in state["state"].items():
            for name, value in entries.items():
                tensors[f"optimizer/{idx}/{name}"] = _tensor_bytes(th.as_tensor(value))
        meta["optimizer_param_groups"] = json.dumps(state["param_groups"])
    write_bytes_atomic(path, save(tensors, metadata=meta))
    return path


def write_bytes_atomic(path: Path, data: bytes) -> None:
    """``data`` to ``path`` whole: written beside it, flushed to the disk, then renamed over it; a
    failed write removes its partial file and leaves ``path`` as it was."""
    tmp = path.with_name(path.name + ".partial")
    try:
        with open(tmp, "wb") as fh:
            fh.write(data)
            fh.flush()
            os.fsync(fh.fileno())
        os.replace(tmp, path)
    except BaseException:
        with contextlib.suppress(OSError):
            tmp.unlink()
        raise


def read_checkpoint(path: Union[str, Path]) -> Checkpoint:
    """Read a checkpoint (a run folder or its ``model.safetensors``); never runs code from it.
    Its metadata is checked against what the trainer writes, and its weights must be finite:
    anything else is a :class:`CheckpointError` naming the file and the field."""
    path, tensors, meta = read_tensors(path, "pt")
    try:
        counters = _counters(json.loads(meta.get("counters", "{}")))
        groups = _param_groups(json.loads(meta["optimizer_param_groups"])) if "optimizer_param_groups" in meta else None
        run_state = _run_state(json.loads(meta["run_state"])) if "run_state" in meta else None
    except RecursionError:
        raise CheckpointError(f"{path}: malformed metadata (JSON nested too deep)") from None
    except (ValueError, TypeError, AttributeError, KeyError, OverflowError) as exc:
        raise CheckpointError(f"{path}: malformed metadata ({exc})") from None
    policy = {k[len("policy/"):]: v for k, v in tensors.items() if k.startswith("policy/")}
    if not policy:
        raise CheckpointError(f"{path} holds no policy weights")
    bad = next((k for k, v in policy.items() if not bool(th.isfinite(v).all())), None)
    if bad is not None:
        raise CheckpointError(f"{path}: policy/{bad} holds non-finite values (NaN or infinity)")
    optimizer = None
    if groups is not None:
        state: dict[int, dict[str, th.Tensor]] = {}
        for key, value in tensors.items():
            if key.startswith("optimizer/"):
                parts = key.split("/", 2)
                if len(parts) != 3 or not parts[1].isdigit():
                    raise CheckpointError(f"{path}: malformed optimiser tensor name {key!r}")
                state.setdefault(int(parts[1]), {})[parts[2]] = value
        # JSON has no tuples: give settings such as Adam's ``betas`` back their type
        groups = [{k: (v if k == "params" or not isinstance(v, list) else tuple(v)) for k, v in g.items()}
                  for g in groups]
        optimizer = {"state": state, "param_groups": groups}
    unknown = sorted(k for k in tensors if not k.startswith(("policy/", "optimizer/")))
    if unknown:
        raise CheckpointError(f"{path}: unexpected tensors {unknown[:3]} (neither policy/ nor optimizer/)")
    return Checkpoint(path, policy, optimizer, counters, run_state)


def _counters(saved: Any) -> dict[str, int]:
    if not isinstance(saved, dict):
        raise ValueError(f"counters must be a JSON object, got {type(saved).__name__}")
    out = {}
    for key, value in saved.items():
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            raise ValueError(f"counters.{key} must be a whole number >= 0, got {value!r}")
        out[str(key)] = value
    return out


def _param_groups(saved: Any) -> list[dict]:
    if not isinstance(saved, list) or not all(isinstance(g, dict) for g in saved):
        raise ValueError("optimizer_param_groups must be a list of JSON objects")
    for g in saved:
        params = g.get("params")
        if not isinstance(params, list) or not all(isinstance(p, int) and not isinstance(p, bool) for p in params):
            raise ValueError("optimizer_param_groups[].params must be a list of whole numbers")
    return saved


def _run_state(saved: Any) -> dict[str, float]:
    wall, steps = float(saved["wall_s"]), int(saved["agent_steps"])
    if not (math.isfinite(wall) and wall >= 0 and steps >= 0):
        raise ValueError(f"run_state out of range: {saved!r}")
    return {"wall_s": wall, "agent_steps": steps}


def load_policy_weights(policy: th.nn.Module, ckpt: Checkpoint, *, actor_only_ok: bool = False) -> None:
    """Copy the checkpoint's weights into ``policy``; every key and shape must match. With
    ``actor_only_ok`` (loading to act, never to train), a checkpoint holding exactly the actor's
    tensors (a sweep trial's kept weights: :mod:`training.sweeps.kept`) also loads; the critic,
    which acting never runs, keeps its initial values."""
    from box2d_driving.policies.numpy_actor import is_actor_key

    mine = policy.state_dict()
    actor_only = actor_only_ok and bool(ckpt.policy) and all(is_actor_key(k) for k in ckpt.policy)
    wanted = {k for k in mine if is_actor_key(k)} if actor_only else set(mine.keys())
    if wanted != ckpt.policy.keys():
        missing, extra = sorted(wanted - ckpt.policy.keys()), sorted(ckpt.policy.keys() - wanted)
        raise CheckpointError(f"{ckpt.path} does not fit this network (missing {missing[:3]}, "
                              f"unexpected {extra[:3]}): another critic or scenario?")
    bad = [k for k in wanted if mine[k].shape != ckpt.policy[k].shape]
    if bad:
        raise CheckpointError(f"{ckpt.path} does not fit this network: {bad[0]} is "
                              f"{tuple(ckpt.policy[bad[0]].shape)}, the model's {tuple(mine[bad[0]].shape)}")
    policy.load_state_dict(ckpt.policy, strict=not actor_only)


def restore_model(model: Any, ckpt: Checkpoint, *, optimizer: bool = True) -> None:
    """Weights, optimiser state (if saved and asked for) and counters of ``ckpt`` into ``model``."""
    load_policy_weights(model.policy, ckpt)
    if optimizer:
        if ckpt.optimizer is None:
            raise CheckpointError(f"{ckpt.path} has no optimiser state (a policy for inference "
                                  f"or fine-tuning with --init-from, not a run to --resume)")
        try:
            model.policy.optimizer.load_state_dict(ckpt.optimizer)
        except (ValueError, KeyError, RuntimeError) as exc:
            raise CheckpointError(f"{ckpt.path}: optimiser state does not fit ({exc})") from None
    model.num_timesteps = ckpt.counters.get("num_timesteps", 0)
    model._n_updates = ckpt.counters.get("n_updates", 0)
