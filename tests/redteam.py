"""The red-team table of docs/reliability.md: hostile or broken inputs, each tried for real, and
what the package does with it. ``tests/test_redteam.py`` checks that every attack is refused with
our own error (or handled as the table says) and that the committed table is the one this module
writes now; after a change, regenerate it with

    python -m tests.redteam --write docs/reliability.md

Each attack runs in a scratch folder with a copy of a shipped policy; outcomes name files
relative to that folder, so the table is the same on every machine.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

from tests.helpers import rewrite_checkpoint

ROOT = Path(__file__).resolve().parents[1]
START, END = "<!-- red-team table: start -->", "<!-- red-team table: end -->"


@dataclass(frozen=True)
class Attack:
    kind: str  # the attack class (a row group)
    what: str  # the input tried
    before: str  # what the red-team pass of 3688fe0 saw
    run: Callable[[Path], object]  # tries it in a scratch folder; returns what it got, if anything


def _policy(tmp: Path, name: str = "traffic_lights_4cars") -> Path:
    from box2d_driving.policies.shipped import SHIPPED_POLICIES_DIR

    dst = tmp / "policy"
    shutil.copytree(SHIPPED_POLICIES_DIR / name, dst,
                    ignore=shutil.ignore_patterns("*.mp4", "*.png", "*.npz", "progress*.csv"))
    return dst


def _with_meta(tmp: Path, **meta: str) -> Path:
    return rewrite_checkpoint(_policy(tmp), meta=meta)


def _with_tensor(tmp: Path, key: str, value) -> Path:
    return rewrite_checkpoint(_policy(tmp), tensors={key: value})


def _torch_read(folder: Path):
    from training.runs.checkpoint import read_checkpoint

    return read_checkpoint(folder)


def _numpy_load(folder: Path):
    from box2d_driving.policies import load_trained

    return load_trained(folder)


def _torch_load(folder: Path):
    from training.runs.inference import load_policy

    return load_policy(folder)


def _config(tmp: Path, text: str) -> Path:
    folder = _policy(tmp)
    (folder / "config.json").write_text(text)
    return folder


def _symlinked_config(tmp: Path) -> Path:
    folder = _policy(tmp)
    (folder / "config.json").unlink()
    (folder / "config.json").symlink_to("/dev/zero")
    return folder


def _fifo_config(tmp: Path) -> Path:
    folder = _policy(tmp)
    (folder / "config.json").unlink()
    os.mkfifo(folder / "config.json")
    return folder


def _sparse(tmp: Path) -> Path:
    folder = _policy(tmp)
    with (folder / "model.safetensors").open("r+b") as fh:
        fh.truncate(6 * 2**30)  # 6 GiB on paper, nothing on the disk
    return folder


def _zeros(*shape):
    import torch

    return torch.zeros(*shape)


def _full(value, *shape):
    import torch

    return torch.full(shape, value)


def _edited_config(tmp: Path, name: str = "traffic_lights_4cars", **fields) -> Path:
    folder = _policy(tmp, name)
    config = json.loads((folder / "config.json").read_text())
    config.update(fields)
    (folder / "config.json").write_text(json.dumps(config))
    return folder


def _metrics(tmp: Path, text: str):
    folder = _policy(tmp)
    (folder / "eval" / "metrics.json").write_text(text)
    return f"stop value {_numpy_load(folder).stop_value}"


def _make(env_id: str, **overrides):
    import box2d_driving

    return box2d_driving.make(env_id, **overrides).reset(seed=0) and "made"


def _reset(env_id: str, **kwargs):
    import box2d_driving

    box2d_driving.make(env_id).reset(**kwargs)
    return "reset"


def _osm(tmp: Path, nodes, ways, where):
    from box2d_driving.maps.osm import import_junction
    from tests.osm_fixtures import write_osm

    roadmap = import_junction(write_osm(tmp / "junction.osm", nodes, ways), where)
    return f"imported: {len(roadmap.arms)} arms, {len(roadmap.connectors)} connectors"


_P = {"highway": "primary"}
_CROSS = ({1: (0, 0, {}), 2: (60, 0, {}), 3: (-60, 0, {}), 4: (0, 60, {}), 5: (0, -60, {})},
          {10: ([1, 2], _P), 11: ([3, 1], _P), 12: ([1, 4], _P), 13: ([1, 5], _P)})
_NEGATIVE = ({-k: v for k, v in _CROSS[0].items()}, {-k: ([-r for r in refs], t) for k, (refs, t) in _CROSS[1].items()})
_INBOUND = ({1: (0, 0, {}), 2: (60, 0, {}), 3: (-60, 0, {}), 4: (0, 60, {})},
            {10: ([2, 1], {**_P, "oneway": "yes"}), 11: ([3, 1], {**_P, "oneway": "yes"}),
             12: ([4, 1], {**_P, "oneway": "yes"})})

ATTACKS = [
    Attack("checkpoint metadata", '`counters = {"num_timesteps": Infinity}`', "`OverflowError`",
           lambda t: _torch_read(_with_meta(t, counters='{"num_timesteps": Infinity}'))),
    Attack("checkpoint metadata", "`counters` nested 100,000 deep", "`RecursionError`",
           lambda t: _torch_read(_with_meta(t, counters="[" * 100_000 + "]" * 100_000))),
    Attack("checkpoint metadata", '`optimizer_param_groups = "5"`', "`TypeError`",
           lambda t: _torch_read(_with_meta(t, optimizer_param_groups='"5"'))),
    Attack("checkpoint metadata", "a tensor `optimizer/abc/exp_avg`", "`ValueError: invalid literal for int()`",
           lambda t: _torch_read(rewrite_checkpoint(_policy(t), meta={"optimizer_param_groups": "[]"},
                                                 tensors={"optimizer/abc/exp_avg": _zeros(2)}))),
    Attack("run config", '`critic: "evil"` (torch loader)', "a `ValueError` naming no file",
           lambda t: _torch_load(_edited_config(t, critic="evil"))),
    Attack("run config", "bilevel `spline_hidden: [10**9]` (torch loader)",
           "torch allocated 28 GB before the weights were checked",
           lambda t: _torch_load(_edited_config(t, "lanes_8cars_noise05", spline_hidden=[10**9]))),
    Attack("run config", "bilevel `spline_hidden: [10**9]` (numpy loader)", "loaded a network of another shape",
           lambda t: _numpy_load(_edited_config(t, "lanes_8cars_noise05", spline_hidden=[10**9]))),
    Attack("files beside the weights", "`config.json` nested 100,000 deep", "`RecursionError` in every loader",
           lambda t: _numpy_load(_config(t, "[" * 100_000 + "]" * 100_000))),
    Attack("files beside the weights", "`config.json` a symlink to `/dev/zero`", "read until memory ran out",
           lambda t: _numpy_load(_symlinked_config(t))),
    Attack("files beside the weights", "`config.json` a FIFO", "the loader hung",
           lambda t: _numpy_load(_fifo_config(t))),
    Attack("files beside the weights", "`eval/metrics.json` holding `[1, 2]`", "`AttributeError`",
           lambda t: _metrics(t, "[1, 2]")),
    Attack("files beside the weights", "a corrupt `state.json` on `--resume`", "`KeyError` / `TypeError`",
           lambda t: _resume_with_state(t, '{"decisions": "many"')),
    Attack("weights", "an action head of 100 outputs (numpy loader)", "loaded; action 99 blamed on the agent",
           lambda t: _numpy_load(rewrite_checkpoint(_policy(t), tensors={"policy/action_net.weight": _zeros(100, 256),
                                                   "policy/action_net.bias": _zeros(100)}))),
    Attack("weights", "conv kernel 7 (numpy loader)", "loaded silently",
           lambda t: _numpy_load(_with_tensor(t, "policy/mlp_extractor.actor_encoder.conv.0.weight", _zeros(8, 5, 7)))),
    Attack("weights", "a scalar bias (numpy loader)", "loaded silently",
           lambda t: _numpy_load(_with_tensor(t, "policy/mlp_extractor.actor_mlp.0.bias", _zeros(())))),
    Attack("weights", "all-NaN action head (numpy loader)", "drove with every car braking",
           lambda t: _numpy_load(_with_tensor(t, "policy/action_net.weight", _full(float("nan"), 13, 256)))),
    Attack("weights", "a sparse 6 GiB `model.safetensors`", "raw `MemoryError`",
           lambda t: _numpy_load(_sparse(t))),
    Attack("env settings", '`make("crosswalk-v0", pedestrian_size=1e-5)`', "Box2D assertion at reset",
           lambda t: _make("crosswalk-v0", pedestrian_size=1e-5)),
    Attack("env settings", '`make("real-junction-v0", map="x" * 300)`', "`OSError` ENAMETOOLONG",
           lambda t: _make("real-junction-v0", map="x" * 300)),
    Attack("env settings", '`reset(options="abc")` on a spline env', "`AttributeError`",
           lambda t: _reset("intersection-spline-v0", seed=0, options="abc")),
    Attack("env settings", "`reset(seed=True)`", "accepted",
           lambda t: _reset("intersection-v0", seed=True)),
    Attack("env settings", "`reset(seed=np.int64(5))`", "refused",
           lambda t: _reset("intersection-v0", seed=__import__("numpy").int64(5))),
    Attack("env settings", "`make(\"intersection-v0\", accelerations=np.array(1.0))` (a 0-d array)",
           "\"iteration over a 0-d array\", naming no field",
           lambda t: _make("intersection-v0", accelerations=__import__("numpy").array(1.0))),
    Attack("OSM", "a `(nan, nan)` position", "silently picked node 1",
           lambda t: _osm(t, *_CROSS, (float("nan"), float("nan")))),
    Attack("OSM", "negative node ids", "\"malformed data (IndexError)\"",
           lambda t: _osm(t, *_NEGATIVE, -1)),
    Attack("OSM", "every arm one-way inbound", "imported with 0 connectors",
           lambda t: _osm(t, *_INBOUND, 1)),
]


def _resume_with_state(tmp: Path, text: str):
    from tests.helpers import tiny_train_config
    from training.trainers.trainer import train

    out = tmp / "run"
    train(tiny_train_config(timesteps=160), out)
    (out / "state.json").write_text(text)
    train(tiny_train_config(timesteps=240), out, resume=True)
    return f"resumed to {json.loads((out / 'state.json').read_text())['decisions']} decisions"


OUR_ERRORS = ("CheckpointError", "RunError", "ConfigError", "MapError", "ActionError")


def outcome(attack: Attack) -> str:
    """What the package does with the attack now, as one table cell."""
    with tempfile.TemporaryDirectory() as scratch:
        tmp = Path(scratch).resolve()
        try:
            got = attack.run(tmp)
        except Exception as exc:
            message = str(exc).replace(str(tmp) + "/", "").replace(str(tmp), ".")
            message = re.sub(r"\s+", " ", message)[:140]
            verdict = "refused" if type(exc).__name__ in OUR_ERRORS else "RAW"
            return f"{verdict}: `{type(exc).__name__}`: {message}"
        return f"handled: {got}" if isinstance(got, str) else "handled"


def table() -> str:
    lines = ["| attack class | input | before (3688fe0) | now |", "|---|---|---|---|"]
    for attack in ATTACKS:
        lines.append(f"| {attack.kind} | {attack.what} | {attack.before} | {outcome(attack).replace('|', '/')} |")
    return "\n".join(lines)


def write(page: Path) -> None:
    text = page.read_text()
    if START not in text or END not in text:
        raise SystemExit(f"{page} has no red-team table markers ({START} ... {END})")
    head, rest = text.split(START, 1)
    _, tail = rest.split(END, 1)
    page.write_text(f"{head}{START}\n{table()}\n{END}{tail}")


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m tests.redteam", description=__doc__.split("\n\n")[0])
    parser.add_argument("--write", type=Path, help="rewrite the table between the markers of this page")
    args = parser.parse_args(argv)
    if args.write:
        write(args.write)
        print(f"wrote the red-team table of {args.write}")
    else:
        print(table())
    return 0


if __name__ == "__main__":
    sys.exit(main())
