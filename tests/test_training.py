"""Training stack: slot VecEnv semantics, the trainer (checkpoints, resume, budgets, fine-tunes),
the per-behaviour scripts, inference and the CLI; the buffer and the policy have their own files."""

import dataclasses
import json
from pathlib import Path

import numpy as np
import pytest

th = pytest.importorskip("torch")
pytest.importorskip("stable_baselines3")

import box2d_driving  # noqa: E402
from training.behaviours.scripts import QUICK  # noqa: E402
from training.runs.inference import load_policy  # noqa: E402
from training.ppo.policy import CTDEPolicy  # noqa: E402
from training.trainers.trainer import RunError, TrainConfig, build_model, train  # noqa: E402
from training.ppo.vec_env import SlotVecEnv  # noqa: E402
from tests.helpers import (hand_env, level_index, same_checkpoint_weights, straight_car,  # noqa: E402
                           tiny_train_config)


def _two_car_env():
    # car_0 reaches its goal (5 m) on decision 3; car_1 drives on until the horizon (6)
    return hand_env([straight_car((0, 0), (5, 0)), straight_car((0, -20), (300, -20))], horizon=6)


def test_slot_done_on_the_right_step_then_padding_until_reset():
    venv = SlotVecEnv([_two_car_env])
    lay = venv.layout
    up = level_index(venv.envs[0], 1.5)
    obs = venv.reset()
    assert obs.shape == (2, lay.size) and np.all(obs[:, lay.self_alive] == 1)
    for step in range(1, 7):
        obs, rew, dones, infos = venv.step(np.array([up, up]))
        assert infos[0] is not infos[1]
        if step < 3:
            assert not dones.any()
        if step == 3:
            assert dones.tolist() == [True, False]
            assert infos[0]["arrived"] and infos[0]["TimeLimit.truncated"] is False
            term = infos[0]["terminal_observation"]
            assert term[lay.self_alive] == 1 and term[lay.alive].tolist() == [1, 1]
            assert rew[0] > 0.9  # goal reward
            assert obs[0, lay.self_alive] == 0 and np.all(obs[0, : lay.obs_dim] == 0)
            assert obs[1, lay.alive].tolist() == [0, 1]
        if step in (4, 5):
            assert dones.tolist() == [False, False]
            assert infos[0] == {} and rew[0] == 0.0 and obs[0, lay.self_alive] == 0
        if step == 6:
            assert dones.tolist() == [False, True]
            assert infos[1]["TimeLimit.truncated"] is True
            # the instance reset: both slots carry the new episode's first observation
            assert np.all(obs[:, lay.self_alive] == 1)


def test_team_block_and_own_observation_agree():
    venv = SlotVecEnv([lambda: box2d_driving.make("intersection-v0", num_cars=4)])
    obs = venv.reset()
    lay = venv.layout
    team = obs[0, lay.team].reshape(4, lay.obs_dim)
    for i in range(4):
        np.testing.assert_array_equal(obs[i, lay.own], team[i])
        np.testing.assert_array_equal(obs[i, lay.team], obs[0, lay.team])


def test_vec_env_seeding_is_deterministic_and_attrs_work():
    def make():
        v = SlotVecEnv([lambda: box2d_driving.make("intersection-v0", num_cars=2)] * 2)
        v.seed(5)
        return v
    a, b = make(), make()
    np.testing.assert_array_equal(a.reset(), b.reset())
    assert a.get_attr("decision") == [0, 0, 0, 0]
    assert len(a.env_method("state")) == 4
    a.close()


def test_model_save_load_round_trip(tmp_path):
    """Weights, Adam moments and step, and the counters survive the safetensors checkpoint."""
    from training.runs.checkpoint import read_checkpoint, restore_model, save_model

    cfg = TrainConfig(env_overrides={"num_cars": 2, "horizon": 8}, n_envs=1, batch_decisions=32,
                      minibatch=16, epochs=1)
    venv = SlotVecEnv([lambda: box2d_driving.make("intersection-v0", num_cars=2, horizon=8)])
    model = build_model(cfg, venv)
    model.learn(64)  # two updates: the optimiser has state to save
    obs = th.as_tensor(venv.reset())
    save_model(model, tmp_path / "m.safetensors")
    back = build_model(dataclasses.replace(cfg, seed=7), venv)
    restore_model(back, read_checkpoint(tmp_path / "m.safetensors"))
    assert isinstance(back.policy, CTDEPolicy)
    assert (back.num_timesteps, back._n_updates) == (model.num_timesteps, model._n_updates) == (64, 2)
    with th.no_grad():
        d1 = model.policy.get_distribution(obs).distribution.logits
        d2 = back.policy.get_distribution(obs).distribution.logits
        assert th.equal(d1, d2)
        assert th.equal(model.policy.predict_values(obs), back.policy.predict_values(obs))
    mine, theirs = model.policy.optimizer.state_dict(), back.policy.optimizer.state_dict()
    assert mine["param_groups"] == theirs["param_groups"]
    assert mine["state"].keys() == theirs["state"].keys() and mine["state"]
    for idx, entries in mine["state"].items():
        for name, value in entries.items():
            assert th.equal(value, theirs["state"][idx][name]), (idx, name)


def test_train_writes_checkpoints_logs_and_resumes(tmp_path):
    out = tmp_path / "run"
    stats = train(tiny_train_config(), out)
    assert (out / "model.safetensors").exists() and (out / "config.json").exists()
    assert list((out / "checkpoints").glob("model_*.safetensors"))
    assert not list(out.rglob("*.zip")) and not list(out.rglob("*.partial"))
    assert "rollout/success_rate" in stats
    state = json.loads((out / "state.json").read_text())
    assert state["decisions"] == 320 and state["agent_steps"] > 0
    with pytest.raises(RunError, match="not empty"):
        train(tiny_train_config(), out)
    train(tiny_train_config(timesteps=480), out, resume=True)
    assert json.loads((out / "state.json").read_text())["decisions"] == 480
    train(tiny_train_config(timesteps=640), out, resume=True)
    logs = sorted(p.name for p in out.glob("progress*.csv"))
    assert logs == ["progress.csv", "progress.resumed_000000000320.csv",
                    "progress.resumed_000000000480.csv"]
    # config.json keeps the first leg's settings; each resume records the ones it was given
    assert json.loads((out / "config.json").read_text())["timesteps"] == 320
    assert json.loads((out / "config.resumed_000000000480.json").read_text())["timesteps"] == 640
    assert json.loads((out / "config.json").read_text())["algorithm"] == "ppo"  # how loaders read the folder
    from training.evaluation.plots import read_progress
    assert len(read_progress(out)["time/agent_steps"]) == 8  # 4 + 2 + 2 updates, none lost
    with pytest.raises(RunError, match="env_overrides differs"):
        train(tiny_train_config(env_overrides={"num_cars": 3, "horizon": 8}, timesteps=800), out, resume=True)
    # a wall-clock budget already spent: nothing more is trained
    assert train(tiny_train_config(timesteps=10_000, max_minutes=0.0), out, resume=True) == {}
    assert json.loads((out / "state.json").read_text())["decisions"] == 640
    assert len(list(out.glob("progress*.csv"))) == 3  # and no empty log for it
    assert len(list(out.glob("config.resumed_*.json"))) == 2
    with pytest.raises(RunError, match="no checkpoint"):
        train(tiny_train_config(), tmp_path / "missing", resume=True)

    policy = load_policy(out)
    env = policy.make_env()
    obs, _ = env.reset(seed=0)
    actions = policy.act(obs)
    assert set(actions) == set(obs) and all(0 <= a < 13 for a in actions.values())
    assert policy.act(obs) == actions  # deterministic by default
    while env.agents:
        obs, *_ = env.step(policy.act({a: obs[a] for a in env.agents}))
    with pytest.raises(ValueError, match="observation size"):
        policy.act({"car_0": np.zeros(7, np.float32)})


def test_a_resumed_run_continues_the_same_way_every_time(tmp_path):
    """A sweep trial paused and continued from its checkpoint must learn what any other
    continuation from that checkpoint learns: the resume seeds from the run's seed and the
    decisions done, not from the clock or the process."""
    import shutil

    train(tiny_train_config(timesteps=160), tmp_path / "a")
    shutil.copytree(tmp_path / "a", tmp_path / "b")
    for name in "ab":
        train(tiny_train_config(timesteps=320), tmp_path / name, resume=True)
    assert same_checkpoint_weights(tmp_path / "a", tmp_path / "b")
    train(tiny_train_config(timesteps=320, seed=1), tmp_path / "c")  # a different seed learns differently,
    assert not same_checkpoint_weights(tmp_path / "a", tmp_path / "c")  # so the equality above can fail


def test_load_policy_rejects_bad_checkpoints(tmp_path):
    from training.runs.checkpoint import CheckpointError

    with pytest.raises(CheckpointError, match="no checkpoint"):
        load_policy(tmp_path / "nothing.safetensors")
    bad = tmp_path / "bad"
    bad.mkdir()
    (bad / "config.json").write_text("{}")
    with pytest.raises(CheckpointError, match="model.safetensors is missing"):
        load_policy(bad)
    (bad / "model.safetensors").write_bytes(b"not a checkpoint")
    with pytest.raises(CheckpointError, match="no safetensors header"):
        load_policy(bad)


def test_scripts_quick_train_and_evaluate(tmp_path):
    from training.evaluation import evaluate
    from training.behaviours import traffic_lights

    out = tmp_path / "q"
    argv = ["--out", str(out), "--timesteps", "320", "--n-envs", "2", "--batch-decisions", "80",
            "--num-cars", "2", "--threads", "1", "--epochs", "1"]
    assert traffic_lights.main(argv) == 0
    assert traffic_lights.main(argv) == 2  # refuses to overwrite
    ev = tmp_path / "ev"
    assert evaluate.main(["--checkpoint", str(out), "--episodes", "3", "--out", str(ev),
                          "--video", "1"]) == 0
    metrics = json.loads((ev / "metrics.json").read_text())
    for key in ("success_rate", "collision_rate", "red_light_violation_rate", "mean_time_to_goal"):
        assert key in metrics
    assert metrics["collisions"]["collided_cars"] == round(metrics["collision_rate"] * metrics["cars"])
    for name in ("rollouts.npz", "learning_curves.png", "acceleration_by_light.png",
                 "junction_light.png", "episodes.mp4", "collisions.png"):
        assert (ev / name).stat().st_size > 0
    assert evaluate.main(["--checkpoint", str(out), "--episodes", "3", "--out", str(ev)]) == 2


def test_crosswalk_script_and_evaluation_with_invisible_control(tmp_path):
    from training.behaviours import crosswalk
    from training.evaluation import evaluate

    out = tmp_path / "cw"
    assert crosswalk.main(["--out", str(out), "--timesteps", "320", "--n-envs", "2",
                           "--batch-decisions", "80", "--num-cars", "2", "--threads", "1",
                           "--epochs", "1", "--collision-reward", "-3"]) == 0
    policy = load_policy(out)
    assert policy.env_overrides["collision_reward"] == -3.0  # travels with the checkpoint
    assert policy.make_env().config.collision_reward == -3.0
    ev = tmp_path / "ev"
    assert evaluate.main(["--checkpoint", str(out), "--episodes", "2", "--out", str(ev)]) == 0
    metrics = json.loads((ev / "metrics.json").read_text())
    assert "safe_stopping_share" in metrics and "pedestrian_collision_rate" in metrics
    assert "pedestrian_collision_rate" in metrics["invisible_pedestrians"]
    assert "pedestrian" in metrics["collisions"]["by_kind"]
    for name in ("pedestrian_distance.png", "speed_vs_pedestrian_distance.png",
                 "speed_vs_crosswalk_distance.png"):
        assert (ev / name).stat().st_size > 0


def test_wall_clock_budget_stops_a_run(tmp_path):
    train(tiny_train_config(timesteps=1_000_000, max_minutes=0.05), tmp_path / "budget")
    state = json.loads((tmp_path / "budget" / "state.json").read_text())
    assert 0 < state["decisions"] < 1_000_000
    assert state["wall_s"] >= 3.0


@pytest.mark.e2e
def test_main_job_demo_runs_end_to_end(tmp_path):
    """The README's main job: quick training, its report, the shipped policy's report + video."""
    from training import demo

    out = tmp_path / "demo"
    assert demo.main(["--out", str(out), "--episodes", "5"]) == 0
    quick = json.loads((out / "quick" / "eval" / "metrics.json").read_text())
    shipped = json.loads((out / "shipped" / "metrics.json").read_text())
    assert quick["training"]["decisions"] == QUICK.timesteps
    assert (out / "quick" / "eval" / "learning_curves.png").exists()
    assert (out / "shipped" / "episodes.mp4").stat().st_size > 0
    assert shipped["success_rate"] > 0.8  # the shipped policy drives
    assert demo.main(["--out", str(out)]) == 2  # never overwrites


def test_the_quick_size_is_stated_where_users_read_it():
    """README, tutorial and --quick's help give the decisions QUICK trains, from one dataclass."""
    from training.behaviours.scripts import CommonArgs

    said = f"{QUICK.timesteps:,} decisions"
    root = Path(__file__).resolve().parent.parent
    for text in (CommonArgs.__doc__, (root / "README.md").read_text(),
                 (root / "docs" / "tutorials" / "train-a-rule.md").read_text()):
        assert said in " ".join(text.split())


def test_init_from_copies_weights_across_car_counts(tmp_path):
    from training.runs.checkpoint import read_checkpoint

    train(tiny_train_config(), tmp_path / "four")
    out = tmp_path / "eight"
    cfg = tiny_train_config(env_overrides={"num_cars": 3, "horizon": 8}, timesteps=80,
                init_from=str(tmp_path / "four"))
    cfg.batch_decisions, cfg.n_envs = 3, 1  # one decision per update: weights barely move
    # check the copy itself, before any update
    venv = SlotVecEnv([lambda: box2d_driving.make("intersection-v0", num_cars=3, horizon=8)])
    from training.trainers.trainer import load_weights
    model = build_model(cfg, venv)
    load_weights(model, tmp_path / "four")
    src = read_checkpoint(tmp_path / "four")
    for k, v in src.policy.items():
        assert th.equal(model.policy.state_dict()[k], v)
    train(cfg, out)
    assert (out / "model.safetensors").exists()
    bad = tiny_train_config(env_overrides={"num_cars": 2, "history": 3}, init_from=str(tmp_path / "four"))
    with pytest.raises(RunError, match="observation layout"):
        train(bad, tmp_path / "bad")
    with pytest.raises(RunError, match="no checkpoint"):
        train(tiny_train_config(init_from=str(tmp_path / "nope")), tmp_path / "bad2")


def test_init_from_kept_sweep_weights_copies_the_actor_and_starts_a_fresh_critic(tmp_path):
    """A sweep's kept trial weights hold the actor alone: --init-from copies it bit for bit and
    leaves the critic as a fresh build has it; a file missing part of the actor is refused."""
    from safetensors.numpy import load_file, save_file

    from training.sweeps.kept import keep_final_weights
    from training.trainers.trainer import load_weights

    train(tiny_train_config(), tmp_path / "four")
    kept = keep_final_weights(tmp_path / "four", tmp_path / "kept")
    cfg = tiny_train_config(env_overrides={"num_cars": 3, "horizon": 8})
    venv = SlotVecEnv([lambda: box2d_driving.make("intersection-v0", num_cars=3, horizon=8)])
    th.manual_seed(0)
    model = build_model(cfg, venv)
    fresh = {k: v.clone() for k, v in model.policy.state_dict().items()}
    assert load_weights(model, kept) is False
    full = read_checkpoint_policy(tmp_path / "four")
    now = model.policy.state_dict()
    actor = [k for k in now if k.startswith(("mlp_extractor.actor_", "action_net."))]
    assert actor and len(actor) < len(now)
    for k in now:
        assert th.equal(now[k], full[k] if k in actor else fresh[k]), k
    assert any(not th.equal(fresh[k], full[k]) for k in now if k not in actor)  # the critic did not come along
    # an actor with a layer missing is not an actor: one error naming the file
    from safetensors import safe_open

    with safe_open(str(kept / "model.safetensors"), "np") as f:
        meta = f.metadata()
    tensors = load_file(str(kept / "model.safetensors"))
    tensors.pop("policy/action_net.bias")
    save_file(tensors, str(kept / "model.safetensors"), metadata=meta)
    with pytest.raises(RunError, match="different network"):
        load_weights(build_model(cfg, venv), kept)


def read_checkpoint_policy(path):
    from training.runs.checkpoint import read_checkpoint

    return read_checkpoint(path).policy


def test_init_from_widens_a_policy_to_the_communication_option(tmp_path):
    from training.trainers.trainer import load_ppo, load_weights

    train(tiny_train_config(), tmp_path / "plain")
    src = load_ppo(tmp_path / "plain").policy
    cfg = tiny_train_config(env_overrides={"num_cars": 2, "horizon": 8, "communication": True})
    venv = SlotVecEnv([lambda: box2d_driving.make("intersection-v0", num_cars=2, horizon=8, communication=True)])
    model = build_model(cfg, venv)
    load_weights(model, tmp_path / "plain")
    plain_env = box2d_driving.make("intersection-v0", num_cars=2, horizon=8)
    old_lay, new_lay = plain_env.observation_layout, venv.envs[0].observation_layout
    assert new_lay.satnav_fields == old_lay.satnav_fields + ("bit_received",)
    obs, _ = plain_env.reset(seed=4)
    old_obs = th.as_tensor(np.stack(list(obs.values())))
    lidar, satnav = old_lay.split(old_obs.numpy())
    for bit in (0.0, 1.0):  # whatever bit is received, the new policy starts as the old one
        widened = np.concatenate([satnav, np.full(satnav.shape[:-1] + (1,), bit, np.float32)], axis=-1)
        new_obs = th.as_tensor(np.concatenate([lidar.reshape(len(lidar), -1), widened.reshape(len(lidar), -1)], 1))
        with th.no_grad():
            p_old = src.get_distribution(th.cat([old_obs, th.zeros(len(old_obs), src.observation_space.shape[0]
                                                                    - old_obs.shape[1])], 1)).distribution.probs
            pad = th.zeros(len(new_obs), model.policy.observation_space.shape[0] - new_obs.shape[1])
            p_new = model.policy.get_distribution(th.cat([new_obs, pad], 1)).distribution.probs
        n = p_old.shape[1]
        assert p_new.shape[1] == 2 * n
        assert th.allclose(p_new[:, :n] + p_new[:, n:], p_old, atol=1e-6)
        assert th.allclose(p_new[:, :n], p_new[:, n:], atol=1e-7)  # the bit is a fair coin
    # a checkpoint whose sat-nav has a field the target lacks cannot be widened
    with pytest.raises(RunError, match="observation layout"):
        train(tiny_train_config(init_from=str(tmp_path / "plain"), env_overrides={"num_cars": 2, "history": 3}),
              tmp_path / "bad")


def test_cli_renders_a_trained_policy_and_delegates_train(tmp_path, capsys):
    from box2d_driving.cli import main as cli

    out = tmp_path / "t"
    assert cli(["train", "lights", "--out", str(out), "--timesteps", "160", "--n-envs", "2",
                "--batch-decisions", "80", "--num-cars", "2", "--threads", "1", "--epochs", "1"]) == 0
    video = tmp_path / "v.mp4"
    assert cli(["render", "intersection-v0", "--policy", str(out), "--out", str(video),
                "--set", "render_size=(128, 128)"]) == 0
    assert video.stat().st_size > 0
    assert cli(["render", "highway-v0", "--policy", str(out), "--out", str(tmp_path / "w.mp4")]) == 2
    assert cli(["train", "nope"]) == 2
    assert "trained on intersection-v0" in capsys.readouterr().err


def test_every_behaviour_trains_with_an_algorithm_named_by_its_arguments():
    """Scripts, sweep trials and their checks pick the trainer from one table, by the script's
    arguments: no branch on the behaviour's name anywhere."""
    from dataclasses import dataclass

    from box2d_driving import plugins
    from training.behaviours.algorithms import ALGORITHMS, algorithm_of
    from training.sweeps.spec import algorithm, script_module

    chosen = {b: algorithm(b).name for b in plugins.behaviours()}
    assert chosen["lanes"] == chosen["fast-lanes"] == "bilevel-ppo"
    assert {chosen[b] for b in ("lights", "crosswalk", "real-junction")} == {"ppo"}
    assert {a.name for a in ALGORITHMS} == set(chosen.values())
    for b in chosen:
        assert algorithm_of(script_module(b).Args).budget == ("rounds" if chosen[b] == "bilevel-ppo" else "decisions")

    @dataclass
    class Stranger:
        out: str = "x"

    with pytest.raises(TypeError, match="Stranger derives from no algorithm"):
        algorithm_of(Stranger)


def test_the_log_says_when_the_actors_lidar_encoder_has_died(tmp_path, capsys):
    """progress.csv carries the spread of the LiDAR and of the actor's LiDAR features; once the
    features stop varying while the LiDAR does, one warning says the actor is blind."""
    from training.evaluation.plots import read_progress
    from training.runs.progress import RolloutMetrics

    cfg = TrainConfig(env_overrides={"num_cars": 2, "horizon": 8}, n_envs=1, batch_decisions=32,
                      minibatch=16, epochs=1)
    venv = SlotVecEnv([lambda: box2d_driving.make("intersection-v0", num_cars=2, horizon=8)])
    # ours forced dead; the paper code's linear one cannot die (ours is also often dead from the start)
    for encoder, dead in (("relu", True), ("original", False)):
        out = tmp_path / f"{encoder}{dead}"
        out.mkdir()
        model = build_model(dataclasses.replace(cfg, lidar_encoder=encoder), venv)
        if dead:  # the last ReLU's input negative for every observation: the way ours dies
            with th.no_grad():
                model.policy.mlp_extractor.actor_encoder.layer2.bias.fill_(-1e3)
        from stable_baselines3.common.logger import configure
        model.set_logger(configure(str(out), ["csv"]))
        model.learn(96, callback=RolloutMetrics(out, 96, 0.0, 0, checkpoint_every=100, show_bar=False))
        model.logger.close()
        log = read_progress(out)
        assert len(log["rollout/lidar_feature_spread"]) == 3
        assert min(log["rollout/lidar_input_spread"]) > 1e-3  # the cars see the junction and each other
        err = capsys.readouterr().err
        if dead:
            assert max(log["rollout/lidar_feature_spread"]) < 1e-4
            assert err.count("its encoder is dead") == 1  # once, not every update
        else:
            assert min(log["rollout/lidar_feature_spread"]) > 1e-4 and "dead" not in err


def test_new_runs_build_the_paper_codes_encoder_and_runs_from_before_read_as_ours(tmp_path):
    """The default encoder is the paper code's (ours can be dead from the start); a run folder
    from before the choice was recorded is ours, also when resumed under today's default."""
    from training.runs.weights import weights_encoder
    from training.runs.checkpoint import read_checkpoint
    from training.trainers.trainer import read_train_config

    assert TrainConfig().lidar_encoder == "original"
    out = tmp_path / "old"
    train(tiny_train_config(lidar_encoder="relu"), out)
    saved = json.loads((out / "config.json").read_text())
    del saved["lidar_encoder"]  # as every run of before 2026-12-06 wrote it
    (out / "config.json").write_text(json.dumps(saved))
    assert read_train_config(out / "config.json").lidar_encoder == "relu"
    train(tiny_train_config(timesteps=480), out, resume=True)  # today's default given: the run's own kept
    assert weights_encoder(read_checkpoint(out).policy) == "relu"
    assert load_policy(out).act(load_policy(out).make_env().reset(seed=0)[0])
    train(tiny_train_config(), tmp_path / "new")
    assert weights_encoder(read_checkpoint(tmp_path / "new").policy) == "original"


def test_a_fine_tune_builds_the_encoder_of_the_weights_it_starts_from(tmp_path):
    from training.behaviours.scripts import ScriptArgs, config_from
    from training.trainers.trainer import load_weights

    train(tiny_train_config(lidar_encoder="relu"), tmp_path / "ours")
    train(tiny_train_config(), tmp_path / "papers")
    for source, encoder in (("ours", "relu"), ("papers", "original")):
        args = ScriptArgs(out=str(tmp_path / "x"), init_from=str(tmp_path / source))
        assert config_from("intersection-v0", args).lidar_encoder == encoder
    # asked for another encoder than the weights': one line saying which to give
    args = ScriptArgs(out=str(tmp_path / "x"), init_from=str(tmp_path / "ours"), lidar_encoder="original")
    cfg = config_from("intersection-v0", args)
    venv = SlotVecEnv([lambda: box2d_driving.make("intersection-v0", num_cars=4)])
    with pytest.raises(RunError, match="trained with the LiDAR encoder 'relu'.*--lidar-encoder relu"):
        load_weights(build_model(cfg, venv), tmp_path / "ours")
    # weights that cannot be read: the trainer refuses them (a sweep's trial fails alone), not the config
    missing = config_from("intersection-v0", ScriptArgs(out=str(tmp_path / "x"), init_from=str(tmp_path / "nope")))
    with pytest.raises(RunError, match="no checkpoint"):
        train(dataclasses.replace(missing, timesteps=80), tmp_path / "bad")
    assert not (tmp_path / "bad" / "config.json").exists()
