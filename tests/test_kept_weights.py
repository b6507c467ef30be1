"""Every landed trial keeps its final actor weights (``training/sweeps/kept.py``): small, readable
by the ordinary policy loader, and acting exactly as the run they came from."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from box2d_driving.policies import load_trained
from box2d_driving.policies.checkpoint_file import CheckpointError
from training.sweeps.kept import keep_final_weights, kept_folder

POLICIES = Path(__file__).resolve().parents[1] / "assets" / "policies"


def _actions(policy, seed: int) -> list:
    env = policy.make_env()
    obs, _ = env.reset(seed=seed)
    out = []
    while env.agents:
        act = policy.act({a: obs[a] for a in env.agents})
        out.append(sorted(act.items()))
        obs, *_ = env.step(act)
    return out


def test_a_kept_actor_acts_exactly_as_its_run(tmp_path):
    run = POLICIES / "traffic_lights_4cars_noise05"
    dest = keep_final_weights(run, kept_folder(tmp_path, "lights") / "lights_seed=0")
    assert dest == tmp_path / "weights" / "lights" / "lights_seed=0"
    size = (dest / "model.safetensors").stat().st_size
    assert size < 0.6 * (run / "model.safetensors").stat().st_size  # the critic stays behind
    for seed in (1_500_000_000, 1_500_000_001):
        assert _actions(load_trained(dest), seed) == _actions(load_trained(run), seed)


def test_a_bilevel_run_keeps_both_stages(tmp_path):
    run = POLICIES / "fast_lanes_10cars"
    dest = keep_final_weights(run, tmp_path / "kept")
    assert (dest / "accel" / "model.safetensors").exists() and (dest / "spline" / "model.safetensors").exists()
    assert (dest / "config.json").exists()
    a, b = load_trained(dest), load_trained(run)
    env = b.make_env()
    obs, _ = env.reset(seed=1_500_000_000)
    assert np.array_equal(a.actions(np.stack([obs[k] for k in sorted(obs)])),
                          b.actions(np.stack([obs[k] for k in sorted(obs)])))


def test_keeping_replaces_an_earlier_copy_whole_and_refuses_a_non_run(tmp_path):
    run = POLICIES / "traffic_lights_4cars"
    dest = tmp_path / "kept"
    keep_final_weights(run, dest)
    (dest / "stale.txt").write_text("old")
    keep_final_weights(run, dest)
    assert not (dest / "stale.txt").exists() and not list(tmp_path.glob("*.partial"))
    empty = tmp_path / "empty"
    empty.mkdir()
    with pytest.raises((CheckpointError, OSError)):
        keep_final_weights(empty, tmp_path / "nothing")
    assert not (tmp_path / "nothing").exists()
