"""The spline bandit (one-step env) and the bilevel trainer (Algorithm 1)."""

import csv
import json
import os

import numpy as np
import pytest

import box2d_driving
from training.ppo.bandit import SplineBanditVecEnv
from training.trainers.bilevel import BilevelConfig, train_bilevel
from training.runs.inference import load_policy
from training.trainers.trainer import RunError, TrainConfig


def _always(action):
    return lambda obs: np.full(len(obs), action, dtype=np.int64)


def test_bandit_reward_is_the_inner_episode_return_and_every_slot_is_done():
    def make():
        return box2d_driving.make("intersection-spline-v0", num_cars=4, spline_action="joint")
    bandit = SplineBanditVecEnv([make, make], _always(12), normalise=False)
    bandit.seed(7)
    obs0 = bandit.reset()
    assert obs0.shape == (8, 7)
    actions = np.array([0, 43, 86, 129, 172, 215, 5, 100])
    obs1, rewards, dones, infos = bandit.step(actions)
    assert dones.all() and obs1.shape == obs0.shape
    # replay instance 1 by hand: same seed, same paths, same acceleration policy
    env = make()
    env.reset(seed=7 + 4, options={"spline_actions": actions[4:]})  # slot 4 seeds instance 1
    total = dict.fromkeys(env.possible_agents, 0.0)
    while env.agents:
        _, rew, *_ = env.step({a: 12 for a in env.agents})
        for a, r in rew.items():
            total[a] += r
    assert np.allclose(rewards[4:], [total[a] for a in env.possible_agents])
    assert [i["episode_return"] for i in infos[4:]] == pytest.approx(list(rewards[4:]))


def _looks(n_actions):
    """An acceleration policy that reads every observation value (so a row in the wrong order or
    off by a bit changes the actions), choosing among the accelerations from a little braking up
    (so some cars arrive or crash and others are still driving at the horizon)."""
    low = n_actions // 2 - 2
    return lambda obs: (low + np.floor(np.abs(obs).sum(axis=1) * 1e4) % (n_actions - low)).astype(np.int64)


class _PerInstanceBandit(SplineBanditVecEnv):
    """The reference: each instance's inner episode stepped on its own through the PettingZoo API."""

    def _inner_episodes(self, actions):
        n = self.n_cars
        returns, lane_sum, lane_count = np.zeros(self.num_envs), np.zeros(self.num_envs), np.zeros(self.num_envs)
        outcome = np.zeros((self.num_envs, 2), dtype=bool)
        obs_now = []
        for k, env in enumerate(self.envs):
            obs, infos = env.reset(options={"use_plan": True, "spline_actions": actions[k]})
            obs_now.append(obs)
            self._lane_stats(k, [self._car[a] for a in infos], list(infos.values()), lane_sum, lane_count)
        while any(env.agents for env in self.envs):
            live = [(k, a) for k, env in enumerate(self.envs) for a in env.agents]
            acts = self.accel_policy(np.stack([obs_now[k][a] for k, a in live]))
            per_env = [{} for _ in self.envs]
            for (k, a), act in zip(live, acts):
                per_env[k][a] = int(act)
            for k, env in enumerate(self.envs):
                if not env.agents:
                    continue
                obs, rew, term, trunc, infos = env.step(per_env[k])
                obs_now[k] = obs
                for a, r in rew.items():
                    returns[k * n + self._car[a]] += r
                    if term[a] or trunc[a]:
                        outcome[k * n + self._car[a]] = (infos[a]["arrived"], infos[a]["collided"])
                self._lane_stats(k, [self._car[a] for a in infos], list(infos.values()), lane_sum, lane_count)
        return returns, outcome, lane_sum, lane_count


@pytest.mark.parametrize("env_id, overrides, n_actions", [
    ("intersection-spline-v0", {"num_cars": 4, "lidar_noise": 0.5}, 13), ("highway-spline-v0", {"num_cars": 5}, 25)])
def test_bandit_steps_all_instances_together_exactly_as_each_on_its_own(env_id, overrides, n_actions):
    def make():
        return box2d_driving.make(env_id, **overrides)
    batched = SplineBanditVecEnv([make] * 5, _looks(n_actions), normalise=False)
    reference = _PerInstanceBandit([make] * 5, _looks(n_actions), normalise=False)
    for bandit in (batched, reference):
        bandit.seed(11)
    assert np.array_equal(batched.reset(), reference.reset())
    batched.action_space.seed(0)
    ended = []
    for _ in range(3):  # later steps plan from each instance's own generator, not a seed
        act = np.stack([batched.action_space.sample() for _ in range(batched.num_envs)])
        out_b, out_r = batched.step(act), reference.step(act)
        assert np.array_equal(out_b[0], out_r[0]) and np.array_equal(out_b[1], out_r[1])
        for key in ("episode_return", "arrived", "collided", "junction_lane_position"):
            assert np.array_equal([i[key] for i in out_b[3]], [i[key] for i in out_r[3]], equal_nan=True), key
        ended += [(i["arrived"], i["collided"]) for i in out_b[3]]
    arrived, collided = np.array(ended).T
    assert arrived.any() and collided.any()  # both ways of ending early ...
    assert (arrived | collided).all() != (env_id == "highway-spline-v0")  # ... and, on the highway, the horizon


def test_bandit_normalised_rewards_are_standardised():
    def make():
        return box2d_driving.make("highway-spline-v0", num_cars=5)
    bandit = SplineBanditVecEnv([make, make], _always(20), normalise=True)
    bandit.seed(0)
    bandit.reset()
    _, rewards, _, infos = bandit.step(np.linspace(-1, 1, 10).reshape(10, 1))
    raw = np.array([i["episode_return"] for i in infos])
    assert raw.std() > 0
    assert np.allclose(rewards, (raw - raw.mean()) / (raw.std() + 1e-8), atol=1e-5)


def test_bandit_refuses_fixed_track_envs():
    with pytest.raises(ValueError, match="spline"):
        SplineBanditVecEnv([lambda: box2d_driving.make("intersection-v0")], _always(0))


def _config(env_id="intersection-spline-v0", rounds=2):
    accel = TrainConfig(env_id=env_id, env_overrides={"num_cars": 4}, n_envs=2,
                        batch_decisions=800, minibatch=400, threads=1)
    return BilevelConfig(accel=accel, rounds=rounds, spline_samples=64, spline_n_envs=2,
                         spline_minibatch=32, checkpoint_every=1)


@pytest.mark.parametrize("env_id", ["intersection-spline-v0", "highway-spline-v0"])
def test_bilevel_alternates_checkpoints_both_and_resumes(tmp_path, env_id):
    out = tmp_path / "run"
    row = train_bilevel(_config(env_id), out)
    assert row["round"] == 2
    state = json.loads((out / "state.json").read_text())
    assert state["round"] == 2 and state["spline_samples"] == 2 * 64
    assert state["accel_decisions"] == 2 * 800
    for name in ("accel/model.safetensors", "spline/model.safetensors", "accel/config.json",
                 "checkpoints/round_0002_spline.safetensors"):
        assert (out / name).exists(), name
    assert json.loads((out / "config.json").read_text())["algorithm"] == "bilevel-ppo"
    assert json.loads((out / "accel" / "config.json").read_text())["algorithm"] == "ppo"
    with pytest.raises(RunError, match="not empty"):
        train_bilevel(_config(env_id), out)
    train_bilevel(_config(env_id, rounds=3), out, resume=True)
    rows = list(csv.DictReader((out / "rounds.csv").open()))
    assert [int(r["round"]) for r in rows] == [1, 2, 3]
    # the evaluated policy drives on the paths its own spline policy picks
    policy = load_policy(out)
    env = policy.make_env()
    obs, _ = env.reset(seed=0)
    expected = policy.spline_policy.predict(env.spline_observations, deterministic=True)[0]
    assert np.array_equal(np.asarray(env.spline_actions).ravel(), np.asarray(expected).ravel())
    assert set(policy.act(obs)) == set(env.agents)


def test_bilevel_resume_refuses_missing_or_different_runs(tmp_path):
    with pytest.raises(RunError, match="missing"):
        train_bilevel(_config(), tmp_path / "nothing", resume=True)
    out = tmp_path / "run"
    train_bilevel(_config(rounds=1), out)
    other = _config(rounds=2)
    other.accel.env_overrides = {"num_cars": 8}
    with pytest.raises(RunError, match="env_overrides"):
        train_bilevel(other, out, resume=True)


@pytest.mark.parametrize("env_id", ["intersection-spline-v0", "highway-spline-v0"])
def test_shared_spline_picker_gives_the_greedy_actions_of_the_latest_weights(env_id):
    """The acceleration stage's path picker answers what SB3's deterministic predict answers,
    and follows the spline policy after every ``load`` (the weights live in shared memory)."""
    import torch

    from training.trainers.bilevel import build_spline_model, make_bandit, make_picker
    from training.trainers.trainer import build_model, make_vec_env

    cfg = _config(env_id)
    picker = make_picker(cfg)
    venv = make_vec_env(cfg.accel, spline_policy=picker)
    spline = build_spline_model(cfg, make_bandit(cfg, build_model(cfg.accel, venv)))
    space = venv.envs[0].spline_observation_space
    rng = np.random.default_rng(0)
    obs0 = rng.uniform(0, 1, size=(64,) + space.shape).astype(np.float32)
    for trial in range(3):
        with torch.no_grad():
            for p in spline.policy.parameters():
                p.normal_(0, 2.0 if trial else 0.5)
        picker.load(spline.policy)
        expected = spline.policy.predict(obs0, deterministic=True)[0]
        got = venv.envs[1].spline_policy(obs0)  # the env's picker is the shared one
        assert got.shape == expected.shape and got.dtype.kind == np.asarray(expected).dtype.kind
        if env_id == "intersection-spline-v0":
            assert np.array_equal(got, expected)
        else:
            assert np.allclose(got, expected, atol=1e-5) and (np.abs(got) <= 1).all()
    venv.close()


def test_bilevel_with_env_workers_trains_exactly_as_in_process(tmp_path):
    """With ``num_cpus=2`` the acceleration envs step in worker processes that pick paths from the
    shared spline weights: same rounds, same weights as in the learner's process."""
    from tests.helpers import same_checkpoint_weights

    for name, num_cpus in (("local", 0), ("workers", 2)):
        cfg = _config(rounds=2)
        cfg.accel.num_cpus = num_cpus
        train_bilevel(cfg, tmp_path / name)
    rows = [list(csv.DictReader((tmp_path / n / "rounds.csv").open())) for n in ("local", "workers")]
    for a, b in zip(*rows):
        a.pop("wall_s"), b.pop("wall_s")
        assert a == b
    for stage in ("accel", "spline"):
        assert same_checkpoint_weights(tmp_path / "local" / stage, tmp_path / "workers" / stage), stage


@pytest.mark.parametrize("script,report", [("lanes", "lane_histogram.png"),
                                           ("fast_lanes", "lateral_by_rating.png")])
def test_bilevel_scripts_train_and_evaluate(tmp_path, script, report):
    import importlib

    from training.evaluation import evaluate

    module = importlib.import_module(f"training.{script}")
    out = tmp_path / "run"
    argv = ["--out", str(out), "--rounds", "1", "--spline-samples", "32", "--n-envs", "2",
            "--batch-decisions", "80", "--num-cars", "4", "--threads", "1", "--epochs", "1"]
    assert module.main(argv) == 0
    assert module.main(argv) == 2  # refuses to overwrite
    ev = tmp_path / "ev"
    assert evaluate.main(["--checkpoint", str(out), "--episodes", "2", "--out", str(ev), "--video", "1"]) == 0
    metrics = json.loads((ev / "metrics.json").read_text())
    key = "lanes" if script == "lanes" else "fast_lanes"
    assert key in metrics
    for name in (report, "episodes.mp4", "learning_curves.png"):
        assert (ev / name).stat().st_size > 0, name


def test_lanes_script_takes_the_papers_joint_path_choice_and_refuses_a_typo(tmp_path):
    from training.behaviours.lanes import Args, main
    from training.behaviours.scripts import config_from
    from training.evaluation import evaluate

    assert "spline_action" not in config_from("intersection-spline-v0", Args(), 0).env_overrides
    joint = config_from("intersection-spline-v0", Args(spline_action="joint"), 0)
    assert joint.env_overrides["spline_action"] == "joint"
    tiny = ["--rounds", "1", "--spline-samples", "32", "--n-envs", "2", "--batch-decisions", "80", "--num-cars", "4",
            "--threads", "1", "--epochs", "1"]
    assert main(["--out", str(tmp_path / "typo"), "--spline-action", "jiont", *tiny]) == 2
    assert not (tmp_path / "typo").exists()
    out = tmp_path / "run"
    assert main(["--out", str(out), "--spline-action", "joint", *tiny]) == 0
    policy = load_policy(out)
    assert policy.make_env().spline_action_space == box2d_driving.make(
        "intersection-spline-v0", num_cars=4, spline_action="joint").spline_action_space
    ev = tmp_path / "ev"
    assert evaluate.main(["--checkpoint", str(out), "--episodes", "2", "--out", str(ev)]) == 0
    assert json.loads((ev / "metrics.json").read_text())["trained_on"]["spline_action"] == "joint"


def test_a_round_is_one_transaction_rolled_back_or_forward_after_a_stop(tmp_path, monkeypatch, capsys):
    """A stop while a round is saved leaves the previous round or the new one, never one policy of
    each: before ``state.json.next`` is written the round is rolled back, after it forward."""
    from training.trainers import bilevel

    back = tmp_path / "back"
    train_bilevel(_config(rounds=1), back)
    before = (back / "accel" / "model.safetensors").read_bytes()
    (back / "accel" / "model.safetensors.next").write_bytes(b"half of a round")  # stopped there
    train_bilevel(_config(rounds=2), back, resume=True)
    assert "was rolled back" in capsys.readouterr().err
    assert [int(r["round"]) for r in csv.DictReader((back / "rounds.csv").open())] == [1, 2]
    assert not list(back.rglob("*.next")) and (back / "accel" / "model.safetensors").read_bytes() != before

    forward = tmp_path / "forward"
    train_bilevel(_config(rounds=1), forward)
    real_replace, calls = os.replace, []

    def stop_after_the_first_rename(src, dst):
        if str(src).endswith(".next"):
            calls.append(src)
            if len(calls) == 2:  # the accel policy renamed, the spline policy not yet: stopped
                raise KeyboardInterrupt
        real_replace(src, dst)

    monkeypatch.setattr(bilevel.os, "replace", stop_after_the_first_rename)
    with pytest.raises(KeyboardInterrupt):
        train_bilevel(_config(rounds=2), forward, resume=True)
    monkeypatch.undo()
    assert json.loads((forward / "state.json").read_text())["round"] == 1  # not yet committed in place
    train_bilevel(_config(rounds=3), forward, resume=True)
    assert "was rolled forward" in capsys.readouterr().err
    state = json.loads((forward / "state.json").read_text())
    assert state["round"] == 3 and state["accel_decisions"] == 3 * 800 and state["spline_samples"] == 3 * 64
    assert [int(r["round"]) for r in csv.DictReader((forward / "rounds.csv").open())] == [1, 2, 3]
