"""Checkpoints that cannot run code when they are read.

SB3's ``model.zip`` stores cloudpickled objects, and ``PPO.load`` unpickles them: a crafted file
runs whatever it likes on the machine that loads it. Policies are files people download, so this
project never unpickles a checkpoint. A checkpoint is one ``model.safetensors`` file:

* tensors ``policy/<name>``: the policy's ``state_dict`` (actor, critic, action and value heads);
* tensors ``optimizer/<param index>/<name>``: the Adam state (moments and step), present in
  training checkpoints so that ``--resume`` continues exactly; shipped policies may leave it out;
* string metadata: ``format`` and ``version`` (what this module writes), ``counters`` (JSON:
  ``num_timesteps``, ``n_updates``) and ``optimizer_param_groups`` (JSON).

The network's shape is rebuilt from the run folder's ``config.json`` (plain JSON: env id, env
overrides, critic, PPO settings), never from the checkpoint. safetensors is a JSON header followed
by raw little-endian numbers: reading one parses JSON and copies bytes, nothing else.

An older ``model.zip`` of the user's own can be converted once with
``box2d-driving convert-checkpoint RUN --trust-pickle`` (which unpickles it: see that command).
"""

from __future__ import annotations

import json
import os
import struct
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Optional, Union

import torch as th

FORMAT = "box2d-driving-checkpoint"
VERSION = 1
FILE = "model.safetensors"
LEGACY_FILE = "model.zip"
_MAX_HEADER = 100 * 2**20  # bytes; a safetensors header is JSON, this bounds what we parse


class CheckpointError(ValueError):
    """A checkpoint file is missing, unsafe, unreadable or does not fit the model."""


@dataclass
class Checkpoint:
    """What a ``model.safetensors`` holds: policy weights, optional optimiser state, counters."""

    path: Path
    policy: dict[str, th.Tensor]
    optimizer: Optional[dict[str, Any]]  # an ``optimizer.state_dict()``, or None
    counters: dict[str, int]


def legacy_message(path: Path) -> str:
    return (f"{path} is an SB3 model.zip: it holds pickled Python objects, which can run any code "
            f"when loaded, so it is refused. Shipped and new checkpoints are {FILE} files. If this "
            f"file is your own (you trained it and nobody else could have changed it), convert it "
            f"once: box2d-driving convert-checkpoint {path} --trust-pickle")


def find_checkpoint(path: Union[str, Path]) -> Path:
    """The ``model.safetensors`` of a run folder (or the file itself). A folder that holds only a
    pickled ``model.zip``, or a path to one, is refused with :func:`legacy_message`."""
    path = Path(path)
    if path.is_dir():
        if (path / FILE).is_file():
            return path / FILE
        if (path / LEGACY_FILE).exists():
            raise CheckpointError(legacy_message(path / LEGACY_FILE))
        raise CheckpointError(f"no checkpoint in {path}: {FILE} is missing")
    if not path.exists():
        raise CheckpointError(f"no checkpoint at {path}")
    return path


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


def _check_header(path: Path) -> None:
    """Refuse anything that is not a safetensors file before any library parses it."""
    with path.open("rb") as fh:
        head = fh.read(9)
    if head[:2] == b"PK":
        raise CheckpointError(legacy_message(path))
    if len(head) < 9:
        raise CheckpointError(f"{path} is not a {FORMAT} file (too short)")
    (size,) = struct.unpack("<Q", head[:8])
    if head[8:9] != b"{" or not 2 <= size <= min(_MAX_HEADER, path.stat().st_size - 8):
        raise CheckpointError(f"{path} is not a {FORMAT} file (no safetensors header)")


def read_checkpoint(path: Union[str, Path]) -> Checkpoint:
    """Read a checkpoint (a run folder or its ``model.safetensors``); never runs code from it."""
    from safetensors import safe_open

    path = find_checkpoint(path)
    _check_header(path)
    try:
        with safe_open(str(path), framework="pt") as fh:
            meta = fh.metadata() or {}
            tensors = {key: fh.get_tensor(key) for key in fh.keys()}
    except Exception as exc:  # corrupt or truncated file
        raise CheckpointError(f"{path}: unreadable checkpoint ({exc})") from None
    if meta.get("format") != FORMAT:
        raise CheckpointError(f"{path} is a safetensors file but not a {FORMAT} "
                              f"(format {meta.get('format')!r})")
    if meta.get("version") != str(VERSION):
        raise CheckpointError(f"{path}: checkpoint version {meta.get('version')!r}; this release "
                              f"reads version {VERSION}")
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
