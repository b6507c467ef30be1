"""Learning curves on selection seeds (``box2d-driving curve``): the late-change measure on
hand-built curves, a sweep folder's every trial, the scenario's metrics, and bad folders."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from training.evaluation import checkpoint_curve as cc
from training.sweeps import curves


def test_late_change_of_a_line_is_its_rise_over_the_late_span():
    d = np.arange(1, 11) * 100_000.0  # 0.1 M .. 1.0 M decisions
    v = 0.2 + 0.3 * d / 1e6  # rises 0.3 per million
    # last half: from 0.5 M to 1.0 M, so 0.15
    assert cc.late_change(d, v) == pytest.approx(0.15)
    assert cc.late_change(d, np.full(10, 0.4)) == pytest.approx(0.0, abs=1e-12)


def test_late_change_ignores_the_early_rise_and_missing_values():
    d = np.array([1, 2, 3, 4, 5, 6, 7, 8], dtype=float)
    v = np.array([0.0, 0.5, 0.9, 0.95, 0.95, np.nan, 0.95, 0.95])
    assert cc.late_change(d, v) == pytest.approx(0.0, abs=1e-12)  # flat from 4 on: the rise before is not counted
    assert np.isnan(cc.late_change(d[:1], v[:1]))
    assert np.isnan(cc.late_change(np.array([1.0, 10.0]), np.array([0.1, 0.2])))  # one late checkpoint only


def test_rule_metrics_follow_the_scenario():
    import box2d_driving
    from box2d_driving.metrics.rollouts import run_episodes
    from box2d_driving.policies.scripted import make_policy

    for env_id, extra in (("intersection-v0", "red_light_violation_rate"),
                          ("crosswalk-v0", "pedestrian_collision_rate")):
        env = box2d_driving.make(env_id, num_cars=2)
        table = run_episodes(env, make_policy("full-throttle", env), 2, seed=1_000_000_000)
        got = cc.rule_metrics(env_id, table, env.config)
        assert tuple(got) == cc.curve_metrics(env_id) and extra in got
        assert all(0.0 <= x <= 1.0 or np.isnan(x) for x in got.values())


def _sweep_folder(tmp_path, trained):
    """A sweep folder as ``box2d-driving sweep`` left it before trials trained outside it:
    sweep.json, and a live run folder per trial under tune/ (one trial trained, the other not
    started), which curves still read where a trial has no reported checkpoint."""
    from training.trainers.trainer import train
    from tests.helpers import tiny_train_config

    sweep = tmp_path / "sweep"
    spec = {"behaviour": "lights", "grid": {"lidar_noise": ["0", "0.5"]}, "seeds": 1, "fixed": {},
            "timesteps": 320, "minutes": None, "episodes": 2, "quick": False}
    (sweep / "tune").mkdir(parents=True)
    (sweep / "sweep.json").write_text(json.dumps(spec))
    run = sweep / "tune" / "lights_lidar_noise=0_seed=0" / "run"
    train(tiny_train_config(env_overrides={"num_cars": 2, "horizon": 8, "lidar_noise": 0.0}), run)
    return sweep, run


def test_a_sweep_curve_has_every_started_trials_checkpoints(tmp_path, capsys):
    sweep, run = _sweep_folder(tmp_path, trained=True)
    assert curves.main([str(sweep), "--episodes", "1"]) == 0
    assert "lights_lidar_noise=0.5_seed=0: no run folder here" in capsys.readouterr().out
    rows = list(csv.DictReader((sweep / "curves.csv").open()))
    kept = sorted(int(p.stem.split("_")[-1]) for p in (run / "checkpoints").glob("model_*.safetensors"))
    assert [int(r["decisions"]) for r in rows] == kept and len(kept) >= 2
    assert {r["trial"] for r in rows} == {"lights_lidar_noise=0_seed=0"}
    assert {r["lidar_noise"] for r in rows} == {"0"} and {r["seed"] for r in rows} == {"0"}
    assert set(cc.curve_metrics("intersection-v0")) <= set(rows[0])
    assert {r["first_seed"] for r in rows} == {"1000000000"}  # selection seeds
    # an existing curve is not replaced without --overwrite
    assert curves.main([str(sweep), "--episodes", "1"]) == 2
    assert "--overwrite" in capsys.readouterr().err
    # --finished: only the trials the summary lists as done (here none yet, then the trained one)
    assert curves.main([str(sweep), "--episodes", "1", "--finished", "--out", str(tmp_path / "f")]) == 2
    assert "lights_lidar_noise=0_seed=0: not finished, skipped" in capsys.readouterr().out
    (sweep / "summary.json").write_text(json.dumps({"sweep": {}, "trials": [
        {"trial": "lights_lidar_noise=0_seed=0", "status": "done"},
        {"trial": "lights_lidar_noise=0.5_seed=0", "status": "running"}]}))
    assert curves.main([str(sweep), "--episodes", "1", "--finished", "--out", str(tmp_path / "f")]) == 0
    assert list(csv.DictReader((tmp_path / "f" / "curves.csv").open())) == rows
    assert curves.main([str(run), "--finished"]) == 2
    assert "not a sweep folder" in capsys.readouterr().err


def test_bad_folders_get_one_clear_error(tmp_path, capsys):
    empty = tmp_path / "empty"
    empty.mkdir()
    assert cc.main([str(empty)]) == 2
    assert "no checkpoints" in capsys.readouterr().err
    bilevel = tmp_path / "bilevel"  # a bilevel run without kept rounds
    for sub in ("accel", "spline"):
        (bilevel / sub).mkdir(parents=True)
    (bilevel / "config.json").write_text('{"accel_updates_per_round": 1, "accel": {"batch_decisions": 80}}')
    assert cc.main([str(bilevel)]) == 2
    assert "round_<r>_accel.safetensors" in capsys.readouterr().err
    broken = tmp_path / "broken"
    broken.mkdir()
    (broken / "sweep.json").write_text("{not json")
    assert curves.main([str(broken)]) == 2
    assert "not a sweep folder" in capsys.readouterr().err


def test_the_cli_runs_curve():
    from box2d_driving import cli

    with pytest.raises(SystemExit) as exc:
        cli.main(["curve", "--help"])
    assert exc.value.code == 0


def test_plateau_lines_call_a_flat_a_moving_and_a_noisy_curve():
    from training.results.curves import PLATEAU_TOLERANCE, plateau_lines

    rows = []
    late = {"flat": [0.001, -0.001, 0.0], "falling": [-0.05, -0.06, -0.055], "noisy": [0.2, -0.2, 0.05]}
    for name, changes in late.items():
        for seed, change in enumerate(changes):
            for k in range(5):  # checkpoints at 0, .25, .5, .75, 1.0 M; the late half is .5 - 1.0
                d = 250_000 * k
                rows.append({"g": name, "seed": seed, "decisions": float(d),
                             "m": 0.5 + change * max(0.0, d - 500_000) / 500_000})
    line = plateau_lines(rows, ["g"], [("m", "metric")])[0]
    assert "g flat 0.000 ± " in line and "(stopped moving)" in line
    assert "g falling -0.055 ± 0.012 (still falling)" in line
    # the noisy point's late changes 0.2, -0.2, 0.05 spread by sd 0.202: about 405 seeds, past the 200 looked at
    assert (f"(too noisy to tell: the interval is wider than ±{PLATEAU_TOLERANCE:g}; at this spread more than 200 "
            "seeds would narrow it that far)") in line
    # one seed: its change, and no verdict (no interval to judge by)
    one = plateau_lines([r for r in rows if r["seed"] == 0], ["g"], [("m", "metric")])[0]
    assert "g falling -0.050 (1 seed);" in one and "stopped" not in one and "still" not in one


def test_seeds_to_settle_is_the_first_count_whose_interval_fits_the_tolerance():
    from training.results.curves import PLATEAU_TOLERANCE, seeds_to_settle, settle_words
    from box2d_driving.metrics.stats import mean_ci, t95

    e = mean_ci([-0.060, 0.008, 0.049])  # a 32 M turn-signal point's late changes (bits)
    k = seeds_to_settle(e)
    sd = (sum((x - e.mean) ** 2 for x in e.values) / 2) ** 0.5
    assert t95(k - 1) * sd / k ** 0.5 <= PLATEAU_TOLERANCE < t95(k - 2) * sd / (k - 1) ** 0.5
    assert k == 32
    assert seeds_to_settle(mean_ci([0.01])) is None and seeds_to_settle(mean_ci([0.5, -0.5])) is None
    assert settle_words([5]) == "about 5 seeds" and settle_words([5, 9]) == "about 5-9 seeds per grid point"
    assert settle_words([5, None]) == "more than 200 seeds"


def test_a_bilevel_runs_curve_drives_each_kept_round_with_its_own_spline_policy(tmp_path):
    import torch

    from training.runs.inference import load_bilevel_round
    from training.trainers.bilevel import BilevelConfig, train_bilevel
    from training.trainers.trainer import TrainConfig

    accel = TrainConfig(env_id="intersection-spline-v0", env_overrides={"num_cars": 2, "horizon": 8}, n_envs=2,
                        batch_decisions=80, minibatch=40, epochs=1, threads=1)
    run = tmp_path / "lanes"
    train_bilevel(BilevelConfig(accel=accel, rounds=2, spline_samples=32, spline_n_envs=2, spline_minibatch=16,
                                checkpoint_every=1), run)
    rows = cc.run_curve(run, 1, 1_000_000_000)
    assert [(r["round"], r["decisions"]) for r in rows] == [(1, 80), (2, 160)]
    assert set(cc.curve_metrics("intersection-spline-v0")) <= set(rows[0])
    # each round's own weights: the spline policy of round 1 is not the final one
    first, last = load_bilevel_round(run, 1), load_bilevel_round(run, 2)
    w1 = torch.cat([p.flatten() for p in first.spline_policy.parameters()])
    w2 = torch.cat([p.flatten() for p in last.spline_policy.parameters()])
    assert not torch.equal(w1, w2)
    assert cc.main([str(run), "--episodes", "1"]) == 0 and (run / "checkpoint_curve" / "curve.png").exists()
