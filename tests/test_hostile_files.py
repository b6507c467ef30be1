"""Every file read from a policy or run folder is bounded and checked before use: a hostile or
broken one is one :class:`CheckpointError` naming the file and the field, in both loaders (numpy,
:func:`box2d_driving.policies.load_trained`; torch, :func:`training.load_policy`), never a raw
exception, a hang or an allocation the file chose. Each case is one found by a red-team pass."""

from __future__ import annotations

import json
import os
import shutil
import threading
from pathlib import Path

import numpy as np
import pytest

from box2d_driving.policies import CheckpointError, load_trained
from box2d_driving.policies.checkpoint_file import json_depth, load_json_file, read_bounded
from box2d_driving.policies.shipped import SHIPPED_POLICIES_DIR

pytest.importorskip("torch")
import torch as th

from training.runs.checkpoint import read_checkpoint
from training.runs.inference import load_policy
from tests.helpers import HANG, rewrite_checkpoint

LIGHTS = SHIPPED_POLICIES_DIR / "traffic_lights_4cars"
LANES = SHIPPED_POLICIES_DIR / "lanes_8cars_noise05"
LOADERS = {"numpy": load_trained, "torch": load_policy}


def _copy(tmp_path: Path, src: Path = LIGHTS) -> Path:
    dst = tmp_path / "policy"
    shutil.copytree(src, dst, ignore=shutil.ignore_patterns("*.mp4", "*.png", "*.npz", "progress*.csv"))
    return dst


@pytest.mark.parametrize("loader", LOADERS)
@pytest.mark.parametrize("case,match", [
    ({"tensors": {"policy/action_net.weight": th.zeros(100, 256), "policy/action_net.bias": th.zeros(100)}},
     "action_net"),  # a head of 100 actions: would emit action 99
    ({"tensors": {"policy/mlp_extractor.actor_encoder.conv.0.weight": th.zeros(8, 5, 7)}}, "conv.0.weight"),
    ({"tensors": {"policy/mlp_extractor.actor_encoder.conv.0.weight": th.zeros(8, 5, 0)}}, "conv.0.weight"),
    ({"tensors": {"policy/mlp_extractor.actor_encoder.conv.2.weight": th.zeros(3, 8, 5),
                  "policy/mlp_extractor.actor_encoder.conv.2.bias": th.zeros(3)}}, "conv.2"),
    ({"tensors": {"policy/mlp_extractor.actor_mlp.0.bias": th.zeros(())}}, "actor_mlp.0.bias"),
    ({"tensors": {"policy/action_net.weight": th.full((13, 256), float("nan"))}}, "non-finite"),
    ({"tensors": {"policy/mlp_extractor.actor_mlp.2.weight": th.full((256, 256), float("inf"))}}, "non-finite"),
    ({"drop": "policy/action_net.bias"}, "action_net.bias"),
])
def test_weights_that_do_not_fit_the_network_are_refused_by_both_loaders(tmp_path, loader, case, match):
    folder = _copy(tmp_path)
    rewrite_checkpoint(folder, **case)
    with pytest.raises(CheckpointError, match=match):
        LOADERS[loader](folder)


def test_a_wrong_critic_shape_is_refused_where_the_critic_is_built(tmp_path):
    """The numpy loader runs the actor only; the torch loader builds the critic and checks it."""
    folder = _copy(tmp_path)
    rewrite_checkpoint(folder, tensors={"policy/value_net.weight": th.zeros(1, 7)})
    with pytest.raises(CheckpointError, match="value_net.weight"):
        load_policy(folder)


@pytest.mark.parametrize("meta,match", [
    ({"counters": '{"num_timesteps": Infinity}'}, "malformed metadata"),
    ({"counters": '{"num_timesteps": {"a": {"b": 1}}}'}, "counters.num_timesteps must be a whole number"),
    ({"counters": '"5"'}, "counters must be a JSON object"),
    ({"counters": "[" * 100_000 + "]" * 100_000}, "malformed metadata"),
    ({"optimizer_param_groups": '"5"'}, "optimizer_param_groups must be a list"),
    ({"optimizer_param_groups": '[{"params": "x"}]'}, "params must be a list"),
    ({"run_state": '{"wall_s": NaN, "agent_steps": 1}'}, "run_state out of range"),
])
def test_hostile_metadata_is_one_error_naming_the_file(tmp_path, meta, match):
    folder = _copy(tmp_path)
    rewrite_checkpoint(folder, meta=meta)
    with pytest.raises(CheckpointError, match=match) as caught:
        read_checkpoint(folder)
    assert "model.safetensors" in str(caught.value)


def test_an_optimiser_tensor_with_a_bad_name_is_refused(tmp_path):
    folder = _copy(tmp_path)
    rewrite_checkpoint(folder, tensors={"optimizer/abc/exp_avg": th.zeros(2)}, meta={"optimizer_param_groups": "[]"})
    with pytest.raises(CheckpointError, match="malformed optimiser tensor name 'optimizer/abc/exp_avg'"):
        read_checkpoint(folder)


@pytest.mark.parametrize("loader", LOADERS)
def test_config_files_are_bounded_and_checked(tmp_path, loader):
    folder = _copy(tmp_path)
    config = folder / "config.json"
    good = config.read_text()
    config.write_text("[" * 100_000 + "]" * 100_000)  # nested: RecursionError in a plain json.loads
    with pytest.raises(CheckpointError, match="config.json: JSON nested"):
        LOADERS[loader](folder)
    config.write_text(json.dumps({"a": "[" * 70 + "1" + "]" * 70}).replace('"[', "[").replace(']"', "]"))
    with pytest.raises(CheckpointError, match="nested more than 64 deep"):
        LOADERS[loader](folder)
    config.unlink()
    config.symlink_to("/dev/zero")  # read until memory ran out
    with pytest.raises(CheckpointError, match="config.json is not a regular file"):
        LOADERS[loader](folder)
    config.unlink()
    config.write_text(json.dumps({**json.loads(good), "critic": "evil"}))  # the torch loader builds the critic
    if loader == "torch":
        with pytest.raises(CheckpointError, match="config.json: critic must be one of"):
            LOADERS[loader](folder)


@pytest.mark.skipif(not hasattr(os, "mkfifo"), reason="no FIFOs on this system")
@pytest.mark.parametrize("name", ["config.json", "model.safetensors"])
def test_a_fifo_is_refused_at_once_instead_of_hanging(tmp_path, name):
    folder = _copy(tmp_path)
    (folder / name).unlink()
    os.mkfifo(folder / name)
    caught: list = []
    worker = threading.Thread(target=lambda: caught.append(_raises(load_trained, folder)), daemon=True)
    worker.start()
    worker.join(timeout=HANG)  # bounded by the loader's own work; a FIFO read would block for ever
    assert not worker.is_alive(), "the loader blocked on a FIFO"
    assert isinstance(caught[0], CheckpointError) and "not a regular file" in str(caught[0])


def _raises(fn, *args):
    try:
        fn(*args)
    except Exception as exc:
        return exc
    return None


def test_oversized_files_are_refused_before_they_are_read(tmp_path):
    big = tmp_path / "model.safetensors"
    with big.open("wb") as fh:  # sparse: 6 GiB on paper, nothing on the disk
        fh.truncate(6 * 2**30)
    with pytest.raises(CheckpointError, match="is 6144 MiB, more than the 256 MiB"):
        read_bounded(big, 256 * 2**20)
    with pytest.raises(CheckpointError, match="more than the 256 MiB"):
        load_trained(big)
    small = tmp_path / "x.json"
    small.write_text('{"a": 1}')
    assert load_json_file(small) == {"a": 1} and json_depth({"a": [1, {"b": []}]}) == 4


def test_an_evaluation_report_of_the_wrong_kind_means_no_known_stop_value(tmp_path):
    folder = _copy(tmp_path)
    assert load_trained(folder).stop_value in (0.0, 1.0)
    (folder / "eval" / "metrics.json").write_text("[1, 2]")
    assert load_trained(folder).stop_value is None
    (folder / "eval" / "metrics.json").write_text('{"stop_value": true}')
    assert load_trained(folder).stop_value is None


def test_a_bilevel_config_cannot_make_the_loader_allocate_what_it_declares(tmp_path):
    folder = _copy(tmp_path, LANES)
    config = json.loads((folder / "config.json").read_text())
    config["spline_hidden"] = [10**9]  # torch would have tried to allocate ~28 GB before the weights
    (folder / "config.json").write_text(json.dumps(config))
    with pytest.raises(CheckpointError, match=r"spline_hidden \[1000000000\] does not match the layers"):
        load_policy(folder)
    with pytest.raises(CheckpointError, match=r"spline_hidden \[1000000000\] does not match the layers"):
        load_trained(folder)
    assert np.isfinite(load_trained(LANES).actor.logits(np.zeros((1, load_trained(LANES).obs_dim)))).all()
