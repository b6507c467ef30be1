"""An original-code actor as a policy of ours and back (``training/original/export.py``): the
same logits from the same observation, a folder our loaders read, and the settings of each world
for the other. Uses an actor the original trainer kept (``assets/original/noise0.25_seed0``), so
no sdriving install is needed."""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest
import torch
from safetensors.numpy import load_file
from torch import nn

from training.original import cli
from training.original.commands import OriginalError, OriginalRun
from training.original.export import convert_actor, export_policy, original_spec, preset_config, to_original

RUN = Path(__file__).resolve().parents[1] / "assets" / "original" / "noise0.25_seed0"
ACTOR = RUN / "actors" / "epoch_0075.safetensors"
# a kept trial of the preset's first grid, with our own LiDAR encoder
RELU_PRESET = RUN.parents[1] / "sweeps" / "weights" / "lights-preset" / "lights_lidar_noise=0.25_seed=0"
H, RAYS, SATNAV = 5, 100, 4


def _their_logits(tensors: dict, state: np.ndarray, lidar: np.ndarray) -> np.ndarray:
    """sdriving's ``PPOLidarCategoricalActor._get_logits`` as its source writes it: the LiDAR
    history (channels = frames) through two circular strided convolutions and a pool to 25, then
    the MLP on ``[state history, features]``."""
    conv = nn.Sequential(nn.Conv1d(H, 1, 4, 2, 2, padding_mode="circular"),
                         nn.Conv1d(1, 1, 4, 2, 2, padding_mode="circular"), nn.AdaptiveAvgPool1d(25))
    mlp = nn.Sequential(nn.Linear(H * SATNAV + 25, 256), nn.Tanh(), nn.Linear(256, 256), nn.Tanh(), nn.Linear(256, 13))
    conv.load_state_dict({k[len("actor.lidar_features."):]: torch.from_numpy(v) for k, v in tensors.items()
                          if k.startswith("actor.lidar_features.")})
    mlp.load_state_dict({k[len("actor.logits_net."):]: torch.from_numpy(v) for k, v in tensors.items()
                         if k.startswith("actor.logits_net.")})
    with torch.no_grad():
        features = conv(torch.from_numpy(lidar).view(len(lidar), H, RAYS)).squeeze(1)
        return mlp(torch.cat([torch.from_numpy(state), features], dim=-1)).numpy()


def test_the_converted_actor_gives_the_originals_logits_on_the_same_observation():
    from box2d_driving.policies.numpy_actor import DrivingActor

    theirs = load_file(str(ACTOR))
    ours = convert_actor(theirs)
    actor = DrivingActor({k[len("policy/"):]: v for k, v in ours.items()}, history=H, n_rays=RAYS)
    rng = np.random.default_rng(0)
    lidar = (rng.random((32, H * RAYS)) * (rng.random((32, H * RAYS)) < 0.8) * 0.2).astype(np.float32)
    state = rng.uniform(-1, 1, (32, H * SATNAV)).astype(np.float32)  # frames oldest first, as both stack them
    obs = np.concatenate([lidar, state], axis=1)  # ours: [LiDAR history | sat-nav history]
    np.testing.assert_allclose(actor.logits(obs), _their_logits(theirs, state, lidar), rtol=1e-4, atol=1e-4)
    # and back: the original's names and column order exactly
    back = to_original(ours)
    assert set(back) == {k for k in theirs if k.startswith("actor.")}
    for key, value in back.items():
        np.testing.assert_array_equal(value, theirs[key])


def test_a_broken_or_foreign_actor_is_refused_naming_the_tensor():
    theirs = load_file(str(ACTOR))
    with pytest.raises(OriginalError, match="actor.logits_net.4.bias"):
        convert_actor({k: v for k, v in theirs.items() if k != "actor.logits_net.4.bias"})
    ours = convert_actor(theirs)
    with pytest.raises(OriginalError, match="policy/action_net.weight"):
        to_original({k: v for k, v in ours.items() if k != "policy/action_net.weight"})
    relu = {**ours, "policy/mlp_extractor.actor_encoder.conv.2.weight": np.zeros((1, 8, 5), np.float32)}
    with pytest.raises(OriginalError, match="our own LiDAR encoder"):
        to_original(relu)


def test_each_world_gets_the_others_cars_noise_and_spawn_rule():
    config = preset_config(OriginalRun(lidar_noise=0.5, epochs=1, nagents=8).spec(), 1000)
    env = config.env_overrides
    assert (config.preset, config.lidar_encoder, env["num_cars"], env["lidar_noise"], env["horizon"]) == \
        ("paper", "original", 8, 0.5, 25)
    assert env["approach_order"] == "random" and env["arrived_cars_stay"] and config.ent_coef == 1e-4
    four = preset_config(OriginalRun(lidar_noise=0.25).spec(), 1).env_overrides
    assert four["approach_order"] == "rotate" and four["num_cars"] == 4
    spec = original_spec(json.loads(json.dumps({"algorithm": "ppo", **dataclasses.asdict(config)})))
    assert spec == OriginalRun(lidar_noise=0.5, epochs=1, nagents=8, balance_cars=False).spec()
    turning = OriginalRun(lidar_noise=0.0, epochs=1, nagents=1).spec()
    turning["env_kwargs"]["turns"] = True
    with pytest.raises(OriginalError, match="turns"):
        preset_config(turning, 1)
    for bad, words in (({"preset": None}, "preset"), ({"lidar_encoder": "relu"}, "our own LiDAR encoder"),
                       ({"env_overrides": {**env, "horizon": 36}}, "horizon")):
        with pytest.raises(OriginalError, match=words):
            original_spec({"env_id": "intersection-v0", "preset": "paper", "lidar_encoder": "original",
                           "env_overrides": env, **bad})


def test_an_exported_actor_is_a_policy_of_ours_and_drives_the_paper_preset(tmp_path):
    from box2d_driving.policies import load_trained

    out = export_policy(RUN, ACTOR, tmp_path / "p")
    assert sorted(p.name for p in out.iterdir()) == ["config.json", "model.safetensors", "source.json"]
    assert json.loads((out / "source.json").read_text())["epoch"] == 75
    policy = load_trained(out)
    env = policy.make_env()
    assert env.config.num_cars == 4 and env.config.lidar_noise == 0.25 and env.config.arrived_cars_stay
    obs, _ = env.reset(seed=1_500_000_000)
    acts = policy.act(obs)
    assert set(acts) == set(env.agents) and all(0 <= int(a) < 13 for a in acts.values())
    env.close()
    with pytest.raises(OriginalError, match="exists"):
        export_policy(RUN, ACTOR, out)  # nothing replaced
    assert not (tmp_path / "p.partial").exists()


def test_evaluate_drives_either_world_and_refuses_in_one_line(tmp_path, capsys):
    report = tmp_path / "r.json"
    assert cli.main(["evaluate", "--run", str(RUN), "--world", "ours", "--episodes", "2", "--out", str(report)]) == 0
    metrics = json.loads(report.read_text())
    assert metrics["world"] == "ours" and metrics["run"] == "noise0.25_seed0" and metrics["cars"] == 8
    assert report.with_suffix(".npz").exists()
    kept = tmp_path / "ours.json"
    assert cli.main(["evaluate", "--policy", str(tmp_path / "none"), "--world", "ours", "--episodes", "2",
                     "--out", str(kept)]) == 2
    assert cli.main(["evaluate", "--policy", "traffic_lights_4cars", "--world", "original",
                     "--out", str(kept)]) == 2  # our default world: not the original's
    assert cli.main(["evaluate", "--policy", str(RELU_PRESET), "--world", "original",
                     "--out", str(kept)]) == 2  # our own encoder: not the original's network
    assert cli.main(["evaluate", "--policy", "traffic_lights_4cars", "--epoch", "3", "--world", "ours",
                     "--out", str(kept)]) == 2
    assert cli.main(["evaluate", "--run", str(RUN), "--world", "ours", "--episodes", "2", "--out", str(report)]) == 2
    assert cli.main(["evaluate", "--run", str(RUN), "--set", "drive_on=right", "--out", str(kept)]) == 2
    err = [line for line in capsys.readouterr().err.splitlines() if line]
    assert len(err) == 6 and all("error:" in line for line in err)
    assert "preset None" in err[1] and "our own LiDAR encoder" in err[2] and "--epoch" in err[3]
    assert "exists" in err[4] and "--world ours" in err[5]
    mirrored = tmp_path / "mirrored.json"  # our world's settings changed for the drive
    assert cli.main(["evaluate", "--run", str(RUN), "--world", "ours", "--set", "drive_on=right", "--episodes", "2",
                     "--out", str(mirrored)]) == 0
    assert json.loads(mirrored.read_text())["overrides"] == {"drive_on": "right"}
    assert not kept.exists()


def test_the_lone_car_turning_run_maps_to_the_paper_turns_preset_and_back():
    from training.original.commands import lone_car_run

    run = OriginalRun(lidar_noise=0.0, seed=3, **lone_car_run())
    config = preset_config(run.spec(), 500)
    env = config.env_overrides
    assert config.preset == "paper-turns" and config.ent_coef == 1e-3
    assert (env["num_cars"], env["horizon"], env["turns"], env["turn_motion"], env["light_first_green"]) == \
        (1, 20, True, "paper", 0.125)
    spec = original_spec(json.loads(json.dumps({"algorithm": "ppo", **dataclasses.asdict(config)})))
    assert spec["env_kwargs"] == run.spec()["env_kwargs"]
    with pytest.raises(OriginalError, match="horizon"):  # a turning policy of another horizon
        original_spec({"env_id": "intersection-v0", "preset": "paper-turns", "lidar_encoder": "original",
                       "env_overrides": {**env, "horizon": 25}})
