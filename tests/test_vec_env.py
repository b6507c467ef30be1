"""The SuperSuit-backed slot vector env: the same rollouts in the learner's process and across
worker processes, done on the right decision, truncations as truncations, one info dict per
slot, seeding, attributes, and no process left behind."""

from __future__ import annotations

import json
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
pytest.importorskip("supersuit")

import box2d_driving
from training.ppo.vec_env import make_vec_env_from
from tests.helpers import HANG, slot_rollout

ROOT = Path(__file__).resolve().parent.parent
KW = {"num_cars": 3, "horizon": 6}


def _rollout(num_cpus: int, steps: int = 30, seed: int = 5, transport: str = "supersuit"):
    return slot_rollout(KW, 4, num_cpus, transport, steps, seed)


def _same_infos(a, b):
    assert len(a) == len(b)
    for x, y in zip(a, b):
        assert x.keys() == y.keys()
        for k in x:
            if isinstance(x[k], np.ndarray):
                assert np.array_equal(x[k], y[k]), k
            elif k != "reward_terms":
                assert x[k] == y[k] or (x[k] != x[k] and y[k] != y[k]), k


@pytest.mark.parametrize("num_cpus", [1, 2])
def test_same_rollouts_whatever_the_number_of_workers(num_cpus):
    """SuperSuit's transport hands over every info whole (tests/test_shared_workers.py: ours)."""
    local, workers = _rollout(0), _rollout(num_cpus)
    for a, b in zip(local[:3], workers[:3]):
        assert np.array_equal(a, b)
    for a, b in zip(local[3], workers[3]):
        _same_infos(a, b)
    assert local[2].any()  # cars finished within the rollout


def test_seed_gives_instance_k_the_seed_plus_k():
    venv = make_vec_env_from("intersection-v0", KW, 3, 2)
    try:
        venv.seed(11)
        obs = venv.reset()
    finally:
        venv.close()
    lay = venv.layout
    for k in range(3):
        own, _ = box2d_driving.make("intersection-v0", **KW).reset(seed=11 + k)
        assert np.array_equal(obs[k * 3:(k + 1) * 3, lay.own], np.stack(list(own.values())))


def test_done_on_the_right_decision_with_truncation_flags_and_terminal_observations():
    venv = make_vec_env_from("intersection-v0", {"num_cars": 2, "horizon": 4}, 2, 2)
    try:
        venv.seed(0)
        venv.reset()
        zero = level = 6  # acceleration 0: nobody arrives in 4 decisions
        for t in range(1, 5):
            _, _, dones, infos = venv.step(np.full(venv.num_envs, zero))
            if t < 4:
                assert not dones.any()
        assert dones.all()  # the horizon ends every car on decision 4 ...
        for info in infos:  # ... as a truncation, with the real last observation
            assert info["TimeLimit.truncated"] is True
            assert info["terminal_observation"].shape == venv.observation_space.shape
            assert info["terminal_observation"][venv.layout.self_alive] == 1.0
        assert len({id(i) for i in infos}) == len(infos)  # one dict per slot
        _, _, _, infos = venv.step(np.full(venv.num_envs, level))  # instances reset themselves
        infos[0]["marker"] = 1
        assert all("marker" not in i for i in infos[1:])
    finally:
        venv.close()


def test_a_crash_is_a_termination_not_a_truncation():
    venv = make_vec_env_from("intersection-v0", {"num_cars": 4, "horizon": 40}, 1, 2)
    try:
        venv.seed(3)
        venv.reset()
        seen = []
        for _ in range(40):
            _, _, dones, infos = venv.step(np.full(venv.num_envs, 12))  # full throttle
            seen += [i for d, i in zip(dones, infos) if d]
    finally:
        venv.close()
    crashed = [i for i in seen if i["collided"]]
    assert crashed and all(i["TimeLimit.truncated"] is False for i in crashed)


def test_attributes_with_workers_and_in_process():
    local = make_vec_env_from("intersection-v0", KW, 2, 0)
    remote = make_vec_env_from("intersection-v0", KW, 2, 2)
    try:
        assert [c.num_cars for c in remote.get_attr("config")] == [3] * 6
        assert local.get_attr("config") == remote.get_attr("config")
        local.set_attr("spline_policy", None)
        with pytest.raises(RuntimeError, match="worker processes"):
            remote.set_attr("spline_policy", None)
        assert remote.env_is_wrapped(object) == [False] * 6
    finally:
        local.close()
        remote.close()


def test_worker_processes_counts_the_processes_that_start(monkeypatch):
    from training.trainers import bench_train
    from training.trainers.trainer import TrainConfig, torch_threads
    from training.ppo.workers import worker_processes

    # runs of ceil(n / workers): 16 over 15 is 8 runs of 2, 16 over 12 too; 4 over 3 is 2 runs of 2
    assert [worker_processes(16, k) for k in (0, 1, 2, 4, 8, 12, 15, 16, 40)] == [0, 1, 2, 4, 8, 8, 8, 16, 16]
    assert [worker_processes(5, k) for k in (2, 3, 4, 5)] == [2, 3, 3, 5]  # 5 over 4: runs 2, 2, 1
    venv = make_vec_env_from("intersection-v0", KW, 4, 3)
    try:
        assert venv.worker_processes == len(venv._inner.procs) == 2
    finally:
        venv.close()
    # the learner's default threads: the cores the processes that start leave free
    monkeypatch.setattr("os.cpu_count", lambda: 16)
    assert torch_threads(TrainConfig(n_envs=16, num_cpus=15)) == 8
    assert torch_threads(TrainConfig(n_envs=16, num_cpus=4)) == 12
    assert torch_threads(TrainConfig(n_envs=16, num_cpus=15, threads=3)) == 3
    # bench --train's default worker counts: one row per distinct number of processes
    assert bench_train.distinct_worker_counts([0, 1, 2, 4, 8, 12], 16) == [0, 1, 2, 4, 8]
    assert bench_train.distinct_worker_counts([0, 1, 2, 4, 8, 16], 16) == [0, 1, 2, 4, 8, 16]


def test_close_ends_the_workers_and_a_forgotten_close_does_not_hang_the_interpreter():
    venv = make_vec_env_from("intersection-v0", KW, 4, 2)
    procs = list(venv._inner.procs)
    assert all(p.is_alive() for p in procs)
    venv.close()
    assert not any(p.is_alive() for p in procs)
    script = textwrap.dedent("""
        from training.ppo.vec_env import make_vec_env_from
        venv = make_vec_env_from("intersection-v0", {"num_cars": 2}, 2, 2)
        venv.seed(0); venv.reset()
        print("done")
    """)
    run = subprocess.run([sys.executable, "-c", script], cwd=ROOT, capture_output=True, text=True, timeout=HANG)
    assert run.returncode == 0 and "done" in run.stdout, run.stderr


@pytest.mark.parametrize("transport", ["shared", "supersuit"])
def test_training_with_workers_matches_in_process_and_resumes(tmp_path, transport):
    from tests.helpers import same_checkpoint_weights, tiny_train_config
    from training.trainers.trainer import train

    def cfg(num_cpus, timesteps=160):
        return tiny_train_config(timesteps=timesteps, checkpoint_every=1, num_cpus=num_cpus, device="cpu",
                                 transport=transport)

    train(cfg(0), tmp_path / "local")
    train(cfg(2), tmp_path / "workers")
    a = json.loads((tmp_path / "local" / "state.json").read_text())
    b = json.loads((tmp_path / "workers" / "state.json").read_text())
    assert a["agent_steps"] == b["agent_steps"]  # the same episodes, so the same live cars
    assert same_checkpoint_weights(tmp_path / "local", tmp_path / "workers")  # the same learning
    train(cfg(2, timesteps=320), tmp_path / "workers", resume=True)
    assert json.loads((tmp_path / "workers" / "state.json").read_text())["decisions"] == 320


def test_training_benchmark_prints_a_table_and_writes_json(tmp_path, capsys):
    from box2d_driving.bench import main as bench
    from training.trainers.trainer import resolve_device

    out = tmp_path / "train.json"
    assert bench(["--train", "--cars", "2", "--n-envs", "2", "--batch-decisions", "160", "--warmup", "1",
                  "--updates", "1", "--num-cpus", "0", "3", "--threads", "1", "2", "--device", "auto",
                  "--json", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "| env workers | transport | overlap | device |" in printed
    assert "machine: " in printed and " cores" in printed
    assert "cores" in json.loads(out.read_text())["machine"]  # a table says where it was measured
    rows = json.loads(out.read_text())["rows"]
    assert [(r["num_cpus"], r["worker_processes"], r["threads"]) for r in rows] == [
        (0, 0, 1), (0, 0, 2), (3, 2, 1), (3, 2, 2)]
    # with workers: our transport and the overlapped loop by default; without, neither applies
    assert [(r["transport"], r["overlap"]) for r in rows] == [("-", False)] * 2 + [("shared", True)] * 2
    assert "| 2 (of 3 asked) | " in printed  # 2 instances over 3 workers start 2 processes
    assert {r["device"] for r in rows} == {resolve_device("auto")}  # auto: the GPU if torch sees one
    for r in rows:
        assert r["agent_steps"] > 0 and r["agent_steps_per_s"] > 0
        assert abs(r["env_share"] + r["inference_share"] + r["update_share"] - 1.0) < 0.05
        assert r["update_gflop"] > 0 and r["update_gflops"] > 0 and r["matmul_gflops"] > 0 and r["bound_gflops"] > 0
        # the limit row: the same vector env, random actions, no learner, as many steps
        assert r["steps"] > 0 and r["limit_agent_steps_per_s"] > 0
        parts_ms = r["env_ms"] + r["inference_ms"] + r["update_ms"]
        assert abs(parts_ms * r["steps"] / 1000.0 - r["seconds"]) < 0.05 * r["seconds"]
    assert "| update GFLOP/s | matmul GFLOP/s |" in printed and "| encoders free: GFLOP/s |" in printed
    assert "| limit: random actions, no learner | of limit |" in printed
    with pytest.raises(SystemExit):  # never replaces a table
        bench(["--train", "--json", str(out)])
    if resolve_device("auto") == "cpu":
        with pytest.raises(SystemExit):  # cuda asked for where torch sees no GPU: a usage error
            bench(["--train", "--devices", "cuda"])


def test_the_training_benchmark_measures_what_train_lights_trains_under_a_preset():
    """``bench --train --preset paper`` builds the config ``train lights --preset paper`` trains
    with (world and update), sizes given on the command line replacing the preset's."""
    from training.behaviours.scripts import ScriptArgs, config_from
    from training.trainers.bench_train import bench_config
    from training.trainers.trainer import TrainConfig

    fields = ("env_overrides", "n_envs", "batch_decisions", "minibatch", "epochs", "ent_coef", "clip_range_vf",
              "kl_stop", "advantage_normalisation", "adam_eps", "max_grad_norm", "bootstrap_truncation",
              "learning_rate", "gamma", "gae_lambda", "clip_range", "target_kl", "preset")
    common = dict(cars=4, lidar_noise=0.25, num_cpus=0, transport="shared", overlap=True, device="cpu",
                  minibatch_by_step=True, threads=None)
    bench = bench_config(preset="paper", **common)
    trained = config_from("intersection-v0", ScriptArgs(preset="paper", num_cars=4, lidar_noise=0.25))
    assert {f: getattr(bench, f) for f in fields} == {f: getattr(trained, f) for f in fields}
    # the paper's update: 20 instances, 32,000 joint steps of 4 cars, one pass in 20 minibatches
    assert (bench.n_envs, bench.batch_decisions, bench.minibatch, bench.epochs) == (20, 128_000, 6_400, 1)
    assert bench.env_overrides["horizon"] == 25 and bench.env_overrides["arrived_cars_stay"] is True
    small = bench_config(preset="paper", n_envs=2, batch_decisions=200, **common)
    assert (small.n_envs, small.batch_decisions, small.minibatch, small.epochs) == (2, 200, 10, 1)
    resized = config_from("intersection-v0", ScriptArgs(preset="paper", num_cars=4, lidar_noise=0.25, n_envs=2,
                                                       batch_decisions=200))
    assert {f: getattr(small, f) for f in fields} == {f: getattr(resized, f) for f in fields}
    assert bench.lidar_encoder == "original"  # the preset's (the paper code's), unless asked otherwise
    assert bench_config(preset="paper", lidar_encoder="relu", **common).lidar_encoder == "relu"
    ours = bench_config(**common)
    assert ours.lidar_encoder == TrainConfig.lidar_encoder
    assert (ours.n_envs, ours.batch_decisions, ours.minibatch, ours.epochs, ours.preset) == (
        TrainConfig.n_envs, TrainConfig.batch_decisions, TrainConfig.minibatch, TrainConfig.epochs, None)
    assert ours.env_overrides == {"num_cars": 4, "lidar_noise": 0.25}


def test_the_training_benchmark_runs_a_preset_and_times_its_epochs(tmp_path, capsys):
    from box2d_driving.bench import main as bench

    out = tmp_path / "paper.json"
    assert bench(["--train", "--preset", "paper", "--cars", "2", "--n-envs", "2", "--batch-decisions", "200",
                  "--warmup", "1", "--updates", "1", "--num-cpus", "0", "--threads", "1", "--device", "cpu",
                  "--lidar-encoder", "original", "relu", "--json", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "(preset paper), 2 cars" in printed
    # one row per encoder asked for, each naming the encoder it trained
    assert [r["lidar_encoder"] for r in json.loads(out.read_text())["rows"]] == ["original", "relu"]
    assert "| LiDAR encoder |" in printed and "| cpu | relu | 1 / 1 |" in printed
    assert "200 slot-decisions per update (1 epoch(s) of minibatch 10)" in printed
    assert "| s per epoch of 32,000 joint steps |" in printed
    row = json.loads(out.read_text())["rows"][0]
    # a joint step: one instance one decision; 50 steps of 2 instances per update of 200 slot-decisions
    assert row["steps"] == 50
    assert abs(row["joint_steps_per_s"] * row["seconds"] - row["steps"] * 2) < 1e-6 * row["steps"]
    assert 0 < row["agent_steps"] <= row["steps"] * 2 * 2
    capsys.readouterr()
    with pytest.raises(SystemExit):  # a preset that does not exist: a usage error naming the choices
        bench(["--train", "--preset", "nonesuch"])
    with pytest.raises(SystemExit):  # a world setting out of range: one line naming it, before any training
        bench(["--train", "--preset", "paper", "--lidar-noise", "1.5", "--json", str(tmp_path / "bad.json")])
    err = capsys.readouterr().err.strip().splitlines()
    assert "nonesuch" in err[-2] and "lidar_noise" in err[-1] and not (tmp_path / "bad.json").exists()


def test_the_limit_row_counts_live_agent_steps_of_the_same_env(monkeypatch):
    import training.trainers.bench_rows as bt
    from training.trainers.trainer import TrainConfig

    cfg = TrainConfig(env_id="intersection-v0", env_overrides={"num_cars": 2}, n_envs=2, num_cpus=0)
    calls, real = [], bt.make_vec_env

    def counting(config):  # the limit row builds the env of the config it measures
        venv = real(config)
        calls.append((config.n_envs, config.num_cpus, venv.num_envs))
        return venv
    monkeypatch.setattr(bt, "make_vec_env", counting)
    assert bt.limit_rate(cfg, 2, 20) > 0
    assert calls == [(2, 0, 4)]  # 2 instances of 2 car slots


def test_world_benchmark_prints_its_table_and_the_machine(tmp_path, capsys):
    from box2d_driving.bench import main as bench

    out = tmp_path / "world.json"
    assert bench(["--seconds", "0.3", "--cars", "2", "--json", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "agent-steps/s" in printed and "machine: " in printed
    saved = json.loads(out.read_text())
    assert saved["results"][0]["agent_steps_per_s"] > 0 and "cores" in saved["machine"]


def test_slot_rows_match_the_env_dicts_step_by_step():
    """Every slot row is [own | team | alive | own alive] of the env's own observation dicts,
    through finishes and resets (a reference written out plainly here)."""
    import box2d_driving
    from training.ppo.vec_env import SlotVecEnv

    def reference(obs, lay, agents):
        team = np.zeros((len(agents), lay.obs_dim), np.float32)
        alive = np.zeros(len(agents), np.float32)
        for i, a in enumerate(agents):
            if a in obs:
                team[i], alive[i] = obs[a], 1.0
        rows = np.zeros((len(agents), lay.size), np.float32)
        for i in range(len(agents)):
            rows[i] = np.concatenate([team[i], team.reshape(-1), alive, [alive[i]]])
        return rows

    venv = SlotVecEnv([lambda: box2d_driving.make("intersection-v0", num_cars=4)])
    env = box2d_driving.make("intersection-v0", num_cars=4)
    venv.seed(11)
    lay, agents = venv.layout, env.possible_agents
    obs_dict, _ = env.reset(seed=11)
    rows = venv.reset()
    rng, resets = np.random.default_rng(0), 0
    for _ in range(120):
        np.testing.assert_array_equal(rows, reference(obs_dict, lay, agents))
        actions = rng.integers(0, 13, size=4)
        rows, _, dones, infos = venv.step(actions)
        obs_dict, _, term, trunc, _ = env.step({a: int(actions[i]) for i, a in enumerate(agents) if a in env.agents})
        for i, a in enumerate(agents):
            if a in obs_dict and (term[a] or trunc[a]):
                assert dones[i]
                np.testing.assert_array_equal(infos[i]["terminal_observation"],
                                              reference(obs_dict, lay, agents)[i])
        obs_dict = {a: o for a, o in obs_dict.items() if a in env.agents}
        if not env.agents:
            obs_dict, _ = env.reset()
            resets += 1
    assert resets >= 2


def test_array_concatenation_steps_exactly_as_supersuits_concat_vec_env():
    """ConcatSlots (whole-array concatenation) returns what SuperSuit's ConcatVecEnv returns."""
    import functools

    from supersuit.vector import ConcatVecEnv

    from training.ppo.vec_env import ConcatSlots, InstanceSlots, _make_env

    def build(cls):
        fns = [functools.partial(InstanceSlots, functools.partial(_make_env, "intersection-v0", KW), k)
               for k in range(3)]
        probe = fns[0]()
        return cls(fns, probe.observation_space, probe.action_space)

    ours, theirs = build(ConcatSlots), build(ConcatVecEnv)
    try:
        for v in (ours, theirs):
            v.reset(options={"slot_seed_base": 11})
        rng = np.random.default_rng(1)
        finished = 0
        for _ in range(20):
            actions = rng.integers(0, 13, ours.num_envs)
            a, b = ours.step(actions), theirs.step(actions)
            for x, y in zip(a[:4], b[:4]):
                assert x.dtype == y.dtype and x.shape == y.shape and np.array_equal(x, y)
            _same_infos(a[4], b[4])
            finished += int(a[2].sum() + a[3].sum())
        assert finished  # cars ended within the steps, so padding and resets were compared too
    finally:
        ours.close(), theirs.close()


def test_worker_path_steps_as_supersuits_proc_concat_vec_and_returns_its_own_objects(monkeypatch):
    """``WorkerSlots`` drops ``ProcConcatVec``'s deep copy of each step's infos: the same steps as
    SuperSuit's class, and nothing returned is the workers' shared buffer or another step's dict."""
    import training.ppo.vec_env as vec_env
    from supersuit.vector import ProcConcatVec

    ours = _rollout(2)
    with monkeypatch.context() as m:
        m.setattr(vec_env, "WorkerSlots", ProcConcatVec)
        theirs = _rollout(2)
    for a, b in zip(ours[:3], theirs[:3]):
        assert np.array_equal(a, b)
    for a, b in zip(ours[3], theirs[3]):
        _same_infos(a, b)

    venv = make_vec_env_from("intersection-v0", KW, 4, 2, transport="supersuit")
    try:
        assert isinstance(venv._inner, vec_env.WorkerSlots)
        venv.seed(3)
        venv.reset()
        rng = np.random.default_rng(1)
        first, _, _, infos1 = venv.step(rng.integers(0, 13, venv.num_envs))
        kept = first.copy()
        _, _, _, infos2 = venv.step(rng.integers(0, 13, venv.num_envs))
    finally:
        venv.close()
    assert np.array_equal(first, kept)  # the next step did not write into the returned array
    assert not {id(i) for i in infos1} & {id(i) for i in infos2}


@pytest.mark.parametrize("transport", ["supersuit", "shared"])
def test_worker_env_inherited_by_a_forked_process_closes_quietly_there(transport):
    """A process forked while a worker vector env is alive (the next env's workers, when one process
    builds several) inherits a copy; closing that copy there must not touch the workers, which are
    not its children (SuperSuit's close fails multiprocessing's child-process assertion)."""
    import multiprocessing as mp

    import training.ppo.vec_env as vec_env

    venv = make_vec_env_from("intersection-v0", KW, 2, 1, transport=transport)
    try:
        assert isinstance(venv._inner, vec_env.WorkerSlots if transport == "supersuit" else vec_env.SharedWorkers)
        child = mp.get_context("fork").Process(target=venv._inner.close)
        child.start()
        child.join(60)
        assert child.exitcode == 0
        venv.reset()  # the workers still answer the process that started them
    finally:
        venv.close()
    assert not any(proc.is_alive() for proc in venv._inner.procs)
