"""The training half of the ``paper`` preset: the update of the paper's own trainer as SB3's
options express it, budgets in the original's epochs of joint steps."""

from __future__ import annotations

import pytest

from training.behaviours.scripts import config_from, run_script
from training.behaviours.traffic_lights import Args
from training.common.cli_args import parse
from training.trainers.presets import TRAINING_PRESETS
from training.trainers.trainer import build_model, make_vec_env


def _config(*argv):
    return config_from("intersection-v0", parse(Args, list(argv)))


def test_the_paper_preset_sets_the_original_update():
    cfg = _config("--preset", "paper", "--num-cars", "4", "--lidar-noise", "0.25", "--original-epochs", "75")
    assert cfg.preset == "paper"
    assert cfg.n_envs == 20
    assert cfg.batch_decisions == 32_000 * 4  # every car of every joint step
    assert cfg.minibatch == 32_000 * 4 // 20
    assert cfg.epochs == 1 and cfg.ent_coef == 1e-4 and cfg.clip_range_vf == 0.2
    assert cfg.timesteps == 75 * 32_000 * 4  # 9.6 M slot-decisions
    assert cfg.env_overrides["horizon"] == 25 and cfg.env_overrides["arrived_cars_stay"]
    assert cfg.env_overrides["lidar_noise"] == 0.25 and cfg.env_overrides["num_cars"] == 4
    eight = _config("--preset", "paper", "--num-cars", "8", "--original-epochs", "500")
    assert eight.batch_decisions == 256_000 and eight.timesteps == 500 * 32_000 * 8


def test_flags_given_away_from_their_defaults_win_over_the_preset():
    cfg = _config("--preset", "paper", "--n-envs", "8", "--ent-coef", "0.01", "--horizon", "30")
    assert cfg.n_envs == 8 and cfg.ent_coef == 0.01 and cfg.env_overrides["horizon"] == 30
    assert cfg.epochs == 1  # the rest stays the preset's


def test_without_a_preset_nothing_changes():
    cfg = _config("--num-cars", "4")
    assert cfg.preset is None and cfg.clip_range_vf is None and cfg.n_envs == 16
    assert cfg.batch_decisions == 32_000 and cfg.epochs == 4 and cfg.ent_coef == 0.01
    assert "arrived_cars_stay" not in cfg.env_overrides


def test_bad_preset_input_is_one_line(tmp_path, capsys):
    for argv in (["--preset", "nope"], ["--preset", "paper", "--original-epochs", "0"]):
        assert run_script("intersection-v0", Args, argv + ["--out", str(tmp_path / "r")], "") == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "error:" in err[0]
        assert not (tmp_path / "r").exists()


def test_the_preset_builds_sb3_with_value_clipping():
    cfg = _config("--preset", "paper", "--quick")
    venv = make_vec_env(cfg)
    try:
        model = build_model(cfg, venv)
        assert model.clip_range_vf is not None and model.clip_range_vf(1.0) == 0.2
        assert model.n_epochs == 1 and model.ent_coef == 1e-4
    finally:
        venv.close()
    assert TRAINING_PRESETS["paper"].slot_decisions_per_update(12) == 384_000
