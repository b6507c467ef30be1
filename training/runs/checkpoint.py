"""Checkpoints that cannot run code when they are read: the trainer's side (torch tensors,
optimiser state, writing). The file format, its safety checks and :class:`CheckpointError` live in
:mod:`box2d_driving.policies.checkpoint_file`, which runs policies without torch; this module
reads the same files into torch and writes them.

An older ``model.zip`` of the user's own can be converted once with
``box2d-driving convert-checkpoint RUN --trust-pickle`` (which unpickles it: see that command).
"""

from __future__ import annotations

import json
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


def _tensor_bytes(t: th.Tensor) -> th.Tensor:
    # safetensors refuses tensors that share storage or are not contiguous: give each its own copy
    return t.detach().to("cpu").contiguous().clone()


def save_model(model: Any, path: Union[str, Path], *, with_optimizer: bool = True) -> Path:
    """Write ``model`` (an SB3 ``PPO``) to ``path`` atomically: a reader sees the old file or the
    whole new one, never half of it."""
    from safetensors.torch import save_file

    path = Path(path)
    tensors = {f"policy/{k}": _tensor_bytes(v) for k, v in model.policy.state_dict().items()}
    meta = {"format": FORMAT, "version": str(VERSION),
            "counters": json.dumps({"num_timesteps": int(model.num_timesteps),
                                    "n_updates": int(getattr(model, "_n_updates", 0))})}
    if with_optimizer:
        state = model.policy.optimizer.state_dict()
        for idx, entries in state["state"].items():
            for name, value in entries.items():
                tensors[f"optimizer/{idx}/{name}"] = _tensor_bytes(th.as_tensor(value))
        meta["optimizer_param_groups"] = json.dumps(state["param_groups"])
    tmp = path.with_name(path.name + ".partial")
    save_file(tensors, str(tmp), metadata=meta)
    os.replace(tmp, path)
    return path


def read_checkpoint(path: Union[str, Path]) -> Checkpoint:
    """Read a checkpoint (a run folder or its ``model.safetensors``); never runs code from it."""
    path, tensors, meta = read_tensors(path, "pt")
    try:
        counters = {k: int(v) for k, v in json.loads(meta.get("counters", "{}")).items()}
        groups = json.loads(meta["optimizer_param_groups"]) if "optimizer_param_groups" in meta else None
    except (ValueError, TypeError, AttributeError) as exc:
        raise CheckpointError(f"{path}: malformed metadata ({exc})") from None
    policy = {k[len("policy/"):]: v for k, v in tensors.items() if k.startswith("policy/")}
    if not policy:
        raise CheckpointError(f"{path} holds no policy weights")
    optimizer = None
    if groups is not None:
        state: dict[int, dict[str, th.Tensor]] = {}
        for key, value in tensors.items():
            if key.startswith("optimizer/"):
                _, idx, name = key.split("/", 2)
                state.setdefault(int(idx), {})[name] = value
        # JSON has no tuples: give settings such as Adam's ``betas`` back their type
        groups = [{k: (v if k == "params" or not isinstance(v, list) else tuple(v)) for k, v in g.items()}
                  for g in groups]
        optimizer = {"state": state, "param_groups": groups}
    return Checkpoint(path, policy, optimizer, counters)


def load_policy_weights(policy: th.nn.Module, ckpt: Checkpoint) -> None:
    """Copy the checkpoint's weights into ``policy``; every key and shape must match."""
    mine = policy.state_dict()
    if mine.keys() != ckpt.policy.keys():
        missing, extra = sorted(mine.keys() - ckpt.policy.keys()), sorted(ckpt.policy.keys() - mine.keys())
        raise CheckpointError(f"{ckpt.path} does not fit this network (missing {missing[:3]}, "
                              f"unexpected {extra[:3]}): another critic or scenario?")
    bad = [k for k in mine if mine[k].shape != ckpt.policy[k].shape]
    if bad:
        raise CheckpointError(f"{ckpt.path} does not fit this network: {bad[0]} is "
                              f"{tuple(ckpt.policy[bad[0]].shape)}, the model's {tuple(mine[bad[0]].shape)}")
    policy.load_state_dict(ckpt.policy)


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
