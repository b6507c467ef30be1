"""The training half of the ``paper`` preset: the update of the paper's own trainer as SB3's
options express it, budgets in the original's epochs of joint steps."""

from __future__ import annotations

import pytest

from training.behaviours.algorithms import run_script
from training.behaviours.scripts import config_from
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
    assert cfg.kl_stop == "actor" and cfg.advantage_normalisation == "per_car"
    assert cfg.value_targets == "rewards_to_go"  # the critic learns discounted rewards (ret_buf)
    assert cfg.adam_eps == 1e-8 and cfg.max_grad_norm is None and cfg.bootstrap_truncation is False
    assert cfg.lidar_encoder == "original"  # sdriving's linear LiDAR convolutions
    assert cfg.timesteps == 75 * 32_000 * 4  # 9.6 M slot-decisions
    assert cfg.env_overrides["horizon"] == 25 and cfg.env_overrides["arrived_cars_stay"]
    assert cfg.env_overrides["lidar_noise"] == 0.25 and cfg.env_overrides["num_cars"] == 4
    eight = _config("--preset", "paper", "--num-cars", "8", "--original-epochs", "500")
    assert eight.batch_decisions == 256_000 and eight.timesteps == 500 * 32_000 * 8


def test_flags_given_away_from_their_defaults_win_over_the_preset():
    cfg = _config("--preset", "paper", "--n-envs", "8", "--ent-coef", "0.01", "--horizon", "30",
                  "--lidar-encoder", "relu")
    assert cfg.n_envs == 8 and cfg.ent_coef == 0.01 and cfg.env_overrides["horizon"] == 30
    assert cfg.lidar_encoder == "relu"
    assert cfg.epochs == 1  # the rest stays the preset's
    assert cfg.value_targets == "rewards_to_go"
    assert _config("--preset", "paper", "--value-targets", "lambda_returns").value_targets == "lambda_returns"
    assert _config("--value-targets", "rewards_to_go").value_targets == "rewards_to_go"
    assert _config().value_targets == "lambda_returns"
    # a batch given keeps the preset's one pass in 20 minibatches, as bench --train --preset sizes it
    smaller = _config("--preset", "paper", "--num-cars", "4", "--batch-decisions", "40000")
    assert (smaller.batch_decisions, smaller.minibatch, smaller.epochs) == (40_000, 2_000, 1)


def test_the_eight_car_run_draws_each_arm_at_random_over_the_preset():
    """The paper's 8-car run has balance_cars false: --approach-order random wins over the
    preset's round robin; without the flag the preset's stays, and a bad value is refused."""
    assert _config("--preset", "paper").env_overrides["approach_order"] == "rotate"
    eight = _config("--preset", "paper", "--num-cars", "8", "--approach-order", "random")
    assert eight.env_overrides["approach_order"] == "random"
    assert "approach_order" not in _config("--num-cars", "4").env_overrides


def test_bad_approach_order_is_one_line(tmp_path, capsys):
    argv = ["--approach-order", "sideways", "--quick", "--out", str(tmp_path / "r")]
    assert run_script("intersection-v0", Args, argv, "") == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "approach_order" in err[0]
    assert not (tmp_path / "r").exists()


def test_without_a_preset_nothing_changes():
    cfg = _config("--num-cars", "4")
    assert cfg.preset is None and cfg.clip_range_vf is None and cfg.n_envs == 16
    assert cfg.batch_decisions == 32_000 and cfg.epochs == 4 and cfg.ent_coef == 0.01
    # the encoder is the paper code's with or without the preset (ours could die: docs/paper_world.md)
    assert cfg.kl_stop == "update" and cfg.advantage_normalisation == "minibatch" and cfg.lidar_encoder == "original"
    assert cfg.adam_eps == 1e-5 and cfg.max_grad_norm == 0.5 and cfg.bootstrap_truncation
    assert "arrived_cars_stay" not in cfg.env_overrides


def test_bad_preset_input_is_one_line(tmp_path, capsys):
    for argv in (["--preset", "nope"], ["--preset", "paper", "--original-epochs", "0"], ["--lidar-encoder", "gelu"],
                 ["--value-targets", "monte_carlo"]):
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


# -- the paper's update rules ----------------------------------------------------------------------
import numpy as np  # noqa: E402
import torch as th  # noqa: E402

from training.ppo.original_update import ActorStopAdam, KLWatch, normalise_per_car  # noqa: E402


def test_per_car_normalisation_on_a_hand_built_update():
    adv = np.array([[1.0, 10.0, 3.0, 30.0], [3.0, 20.0, 5.0, 99.0]])  # 2 steps x 4 slots, 2 cars x 2 instances
    live = np.array([[True, True, True, True], [True, True, True, False]])  # slot 3 padded at step 1
    out = normalise_per_car(adv, live, n_cars=2)
    car0 = np.array([1.0, 3.0, 3.0, 5.0])  # slots 0 and 2
    car1 = np.array([10.0, 30.0, 20.0])  # slots 1 and 3, live only
    assert out[0, 0] == pytest.approx((1.0 - car0.mean()) / (car0.std() + 1e-7))
    assert out[1, 2] == pytest.approx((5.0 - car0.mean()) / (car0.std() + 1e-7))
    assert out[0, 3] == pytest.approx((30.0 - car1.mean()) / (car1.std() + 1e-7))
    assert out[1, 3] == 99.0  # padding untouched
    for cols, values in (((0, 2), out[:, [0, 2]][live[:, [0, 2]]]), ((1, 3), out[:, [1, 3]][live[:, [1, 3]]])):
        assert values.mean() == pytest.approx(0.0, abs=1e-9) and values.std() == pytest.approx(1.0, abs=1e-6)


def test_a_stopped_actor_is_left_alone_while_the_critic_steps():
    th.manual_seed(0)
    actor, critic = th.nn.Linear(3, 2), th.nn.Linear(3, 1)
    opt = ActorStopAdam([*actor.parameters(), *critic.parameters()], lr=0.1, eps=1e-8)
    watch = KLWatch(target_kl=0.01)
    opt.watch, opt.actor_params = watch, list(actor.parameters())
    watch.start_update()
    watch.minibatch(th.zeros(5))
    watch.measure(th.full((5,), -0.1))  # KL 0.1 > 1.5 x 0.01
    assert watch.stopped and watch.stopped_at == 0
    before_a = [p.detach().clone() for p in actor.parameters()]
    before_c = [p.detach().clone() for p in critic.parameters()]
    x = th.randn(4, 3)
    (actor(x).sum() + critic(x).sum()).backward()
    opt.step()
    assert all(th.equal(a, b) for a, b in zip(before_a, actor.parameters()))
    assert not any(th.equal(a, b) for a, b in zip(before_c, critic.parameters()))
    assert all(p.grad is not None for p in actor.parameters())  # gradients handed back
    assert all(p not in opt.state or not opt.state[p] for p in actor.parameters())  # no Adam moments
    watch.start_update()
    assert not watch.stopped


def _one_update(kl_stop):
    # our encoder: with it this seed's approximate KL (a mean of log-ratios, which can be negative)
    # is past the tiny limit from the second minibatch on; the rule does not depend on the network
    cfg = _config("--preset", "paper", "--quick", "--ent-coef", "0.0001", "--lidar-encoder", "relu")
    cfg.kl_stop, cfg.target_kl, cfg.timesteps = kl_stop, 1e-9, 1
    cfg.n_envs, cfg.batch_decisions, cfg.minibatch = 4, 800, 200
    venv = make_vec_env(cfg)
    try:
        model = build_model(cfg, venv)
        from training.trainers.trainer import set_minibatching
        set_minibatching(model, cfg, venv.n_cars)
        venv.seed(0)
        model.learn(1)
        actor = [p.detach().clone() for p in model.policy.actor_parameters()]
        ids = {id(p) for p in model.policy.actor_parameters()}
        critic = [p.detach().clone() for p in model.policy.parameters() if id(p) not in ids]
        watch = getattr(model.policy, "kl_watch", None)
        return actor, critic, watch
    finally:
        venv.close()


def test_the_actor_only_kl_rule_against_sb3s():
    # KL of the first minibatch is 0 (nothing has moved yet): both take one full step; from the
    # second minibatch the KL exceeds the tiny limit: SB3 ends the update, the paper's rule only
    # stops the actor
    actor_a, critic_a, watch = _one_update("actor")
    actor_u, critic_u, _ = _one_update("update")
    assert watch is not None and watch.stopped_at == 1
    assert all(th.equal(a, b) for a, b in zip(actor_a, actor_u))  # the same one actor step
    assert not all(th.equal(a, b) for a, b in zip(critic_a, critic_u))  # the critic trained on


def test_the_horizon_is_terminal_when_truncation_is_not_bootstrapped():
    cfg = _config("--preset", "paper", "--quick")
    cfg.n_envs = 1
    venv = make_vec_env(cfg)
    try:
        assert venv.bootstrap_truncation is False
        venv.seed(0)
        venv.reset()
        seen = []
        for _ in range(26):
            _, _, dones, infos = venv.step(np.full(venv.num_envs, 6))
            seen += [i.get("TimeLimit.truncated") for d, i in zip(dones, infos) if d and "terminal_observation" in i]
        assert seen and not any(seen)
    finally:
        venv.close()
