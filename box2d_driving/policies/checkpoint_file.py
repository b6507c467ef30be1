"""The checkpoint file format, read without any learning library and without running code.

SB3's ``model.zip`` stores cloudpickled objects, and ``PPO.load`` unpickles them: a crafted file
runs whatever it likes on the machine that loads it. Policies are files people download, so this
project never unpickles a checkpoint. A checkpoint is one ``model.safetensors`` file:

* tensors ``policy/<name>``: the policy's ``state_dict`` (actor, critic, action and value heads);
* tensors ``optimizer/<param index>/<name>``: the Adam state (moments and step), present in
  training checkpoints so that ``--resume`` continues exactly; shipped policies may leave it out;
* string metadata: ``format`` and ``version`` (what the trainer writes), ``counters`` (JSON:
  ``num_timesteps``, ``n_updates``) and ``optimizer_param_groups`` (JSON).

The network's shape is rebuilt from the run folder's ``config.json`` (plain JSON: env id, env
overrides, critic, PPO settings), never from the checkpoint. safetensors is a JSON header followed
by raw little-endian numbers: reading one parses JSON and copies bytes, nothing else.

This module reads the file into numpy arrays (:func:`read_arrays`), which is all that running a
policy needs (:mod:`box2d_driving.policies.trained`); the trainer reads the same files into torch
tensors with the same checks.
"""

from __future__ import annotations

import json
import struct
from pathlib import Path
from typing import Any, Optional, Union

import numpy as np

FORMAT = "box2d-driving-checkpoint"
VERSION = 1
FILE = "model.safetensors"
LEGACY_FILE = "model.zip"
MAX_HEADER = 100 * 2**20  # bytes; a safetensors header is JSON, this bounds what we parse
# the largest checkpoint read (bytes): ours are under 2 MB with the optimiser state; a file far
# beyond is not one of ours, and reading it whole could exhaust memory
MAX_CHECKPOINT_BYTES = 256 * 2**20
MAX_JSON_BYTES = 16 * 2**20  # a run's config.json, state.json, eval/metrics.json
MAX_JSON_DEPTH = 64  # nesting of a JSON file we read (ours nest 4 deep)


class CheckpointError(ValueError):
    """A checkpoint file is missing, unsafe, unreadable or does not fit the model."""


def legacy_message(path: Path) -> str:
    """Why an SB3 ``model.zip`` at ``path`` is refused, and how its owner converts it."""
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
        if (path / FILE).exists():
            raise CheckpointError(f"{path / FILE} is not a regular file")
        if (path / LEGACY_FILE).exists():
            raise CheckpointError(legacy_message(path / LEGACY_FILE))
        raise CheckpointError(f"no checkpoint in {path}: {FILE} is missing")
    if not path.exists():
        raise CheckpointError(f"no checkpoint at {path}")
    return path


def check_header(path: Path, data: bytes) -> int:
    """Refuse anything that is not a safetensors file before any library parses it; ``data``: the
    file's bytes. Returns the length of its JSON header (which starts at byte 8)."""
    if data[:2] == b"PK":
        raise CheckpointError(legacy_message(path))
    if len(data) < 9:
        raise CheckpointError(f"{path} is not a {FORMAT} file (too short)")
    (size,) = struct.unpack("<Q", data[:8])
    if data[8:9] != b"{" or not 2 <= size <= min(MAX_HEADER, len(data) - 8):
        raise CheckpointError(f"{path} is not a {FORMAT} file (no safetensors header)")
    return size


def check_metadata(path: Path, meta: dict[str, str]) -> None:
    """The file's ``format`` and ``version`` must be the ones this release reads."""
    if meta.get("format") != FORMAT:
        raise CheckpointError(f"{path} is a safetensors file but not a {FORMAT} "
                              f"(format {meta.get('format')!r})")
    if meta.get("version") != str(VERSION):
        raise CheckpointError(f"{path}: checkpoint version {meta.get('version')!r}; this release "
                              f"reads version {VERSION}")


def read_tensors(path: Union[str, Path], framework: str) -> tuple[Path, dict[str, Any], dict[str, str]]:
    """``(file, every tensor by key, metadata)`` of a checkpoint (a run folder or its
    ``model.safetensors``), as ``framework`` arrays (``"numpy"`` here, ``"pt"`` in the trainer),
    after the header and the format and version are checked; never runs code from the file.

    The file is read whole into memory, not memory-mapped: arrays mapped from a file that another
    process rewrites in place (a sweep's trial folder while Ray Tune syncs it) end the reading
    process with SIGBUS, while a copy can at worst be refused here as unreadable."""
    path = find_checkpoint(path)
    data = read_bounded(path, MAX_CHECKPOINT_BYTES, CheckpointError)  # once: the header checked is the one parsed
    size = check_header(path, data)
    try:
        meta = json.loads(data[8:8 + size]).get("__metadata__") or {}
        tensors: dict[str, Any]
        if framework == "pt":
            from safetensors.torch import load as load_torch

            tensors = load_torch(data)
        else:
            from safetensors.numpy import load as load_numpy

            tensors = load_numpy(data)
    except Exception as exc:  # corrupt or truncated file
        raise CheckpointError(f"{path}: unreadable checkpoint ({exc})") from None
    check_metadata(path, meta)
    return path, tensors, meta


def read_arrays(path: Union[str, Path]) -> tuple[Path, dict[str, np.ndarray], dict[str, str]]:
    """``(file, policy arrays by state_dict name, metadata)`` of a checkpoint, read with the
    safetensors numpy API (:func:`read_tensors`)."""
    path, tensors, meta = read_tensors(path, "numpy")
    policy = {key[len("policy/"):]: value for key, value in tensors.items() if key.startswith("policy/")}
    if not policy:
        raise CheckpointError(f"{path} holds no policy weights")
    for key, value in policy.items():
        if not np.issubdtype(value.dtype, np.number) or not np.isfinite(value).all():
            raise CheckpointError(f"{path}: policy/{key} holds non-finite or non-numeric values")
    return path, policy, meta


ALGORITHMS = ("ppo", "bilevel-ppo")  # the algorithms a run folder's config.json may name


def run_algorithm(path: Union[str, Path]) -> Optional[str]:
    """The algorithm that trained the run folder ``path``, as its ``config.json`` records it
    (``"ppo"`` or ``"bilevel-ppo"``); for a folder written before runs recorded it, ``bilevel-ppo``
    where ``accel/`` and ``spline/`` sit beside the config, ``ppo`` otherwise. None where ``path``
    is not a folder with a ``config.json``. An unknown name is a :class:`CheckpointError`."""
    path = Path(path)
    if not (path.is_dir() and (path / "config.json").is_file()):
        return None
    recorded = read_json(path / "config.json").get("algorithm")
    if recorded is None:
        return "bilevel-ppo" if (path / "spline").is_dir() and (path / "accel").is_dir() else "ppo"
    if recorded not in ALGORITHMS:
        raise CheckpointError(f"{path / 'config.json'}: algorithm {recorded!r} is none this package reads "
                              f"({', '.join(ALGORITHMS)})")
    return recorded


def is_bilevel_run(path: Union[str, Path]) -> bool:
    """Whether ``path`` is a bilevel run folder (:func:`run_algorithm`): ``accel/`` (the
    acceleration policy) and ``spline/`` (the path-choosing policy) beside one ``config.json``."""
    return run_algorithm(path) == "bilevel-ppo"


def find_config(model_path: Path) -> Path:
    """The run's ``config.json``: beside the model file, or one folder up (bilevel runs)."""
    for folder in (model_path.parent, model_path.parent.parent):
        if (folder / "config.json").exists():
            return folder / "config.json"
    raise CheckpointError(f"no config.json next to {model_path} or in its parent folder")


def read_bounded(path: Path, limit: int, error: type = CheckpointError) -> bytes:
    """The bytes of the regular file ``path``, refused (as ``error`` naming it) when it is not a
    regular file (a FIFO would block, a device never end) or is larger than ``limit`` bytes."""
    import os
    import stat

    try:
        with open(path, "rb", opener=lambda p, flags: os.open(p, flags | getattr(os, "O_NONBLOCK", 0))) as fh:
            info = os.fstat(fh.fileno())  # the file opened, not one swapped in after a check
            if not stat.S_ISREG(info.st_mode):
                raise error(f"{path} is not a regular file")
            if info.st_size > limit:
                raise error(f"{path} is {info.st_size / 2**20:.0f} MiB, more than the {limit / 2**20:.0f} MiB "
                            f"a file of this kind can be")
            data = fh.read(limit + 1)
    except OSError as exc:
        raise error(f"{path}: cannot read it ({exc.strerror or exc})") from None
    if len(data) > limit:  # grew while it was read
        raise error(f"{path} is larger than the {limit / 2**20:.0f} MiB a file of this kind can be")
    return data


def json_depth(value: Any, limit: int = MAX_JSON_DEPTH) -> int:
    """Nesting depth of a parsed JSON value (iteratively; ``limit + 1`` once past ``limit``)."""
    deepest, stack = 0, [(value, 1)]
    while stack:
        item, depth = stack.pop()
        if isinstance(item, (dict, list)):
            deepest = max(deepest, depth)
            if deepest > limit:
                return deepest
            stack.extend((v, depth + 1) for v in (item.values() if isinstance(item, dict) else item))
    return deepest


def load_json_file(path: Path, error: type = CheckpointError, limit: int = MAX_JSON_BYTES) -> Any:
    """A JSON file we read from a run or policy folder: a regular file of at most ``limit``
    bytes, nested at most :data:`MAX_JSON_DEPTH` deep; anything else is ``error`` naming it."""
    text = read_bounded(path, limit, error)
    try:
        data = json.loads(text)
    except RecursionError:
        raise error(f"{path}: JSON nested too deep") from None
    except ValueError as exc:
        raise error(f"{path}: not valid JSON ({exc})") from None
    if json_depth(data) > MAX_JSON_DEPTH:
        raise error(f"{path}: JSON nested more than {MAX_JSON_DEPTH} deep")
    return data


def read_json(path: Path) -> dict:
    """A run's JSON config as a dict, or :class:`CheckpointError` naming the file."""
    data = load_json_file(path)
    if not isinstance(data, dict):
        raise CheckpointError(f"{path}: expected a JSON object")
    return data
