"""The overlapped rollout loop (``training/ppo/overlapped.py``): the same rollouts, bit for bit, as
SB3's ``collect_rollouts`` for any number of workers, and so the same weights; a stop mid-rollout
leaves no step in flight; without workers SB3's loop runs."""

from __future__ import annotations

import numpy as np
import pytest
import torch as th

pytest.importorskip("stable_baselines3")

from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.logger import configure

from tests.helpers import same_checkpoint_weights, tiny_train_config
from training.trainers.trainer import build_model, make_vec_env, set_minibatching, train

BUFFER_FIELDS = ("observations", "actions", "rewards", "episode_starts", "values", "log_probs", "returns",
                 "advantages", "mask")


def _config(num_cpus: int, overlap: bool, **kw):
    # 3 cars, horizon 5: cars finish by goal, crash and horizon within a rollout of 12 steps
    return tiny_train_config(env_overrides={"num_cars": 3, "horizon": 5}, n_envs=3, batch_decisions=108, minibatch=36,
                             num_cpus=num_cpus, overlap=overlap, device="cpu", **kw)


def _rollouts(tmp_path, num_cpus: int, overlap: bool, rollouts: int = 2, callback=None):
    """The buffers of ``rollouts`` rollouts of a fresh model (an update between them), the model's
    counters and whether the overlapped loop ran."""
    cfg = _config(num_cpus, overlap)
    th.set_num_threads(1)
    venv = make_vec_env(cfg)
    try:
        model = build_model(cfg, venv)
        set_minibatching(model, cfg, venv.n_cars)
        model.set_logger(configure(str(tmp_path), []))
        venv.seed(cfg.seed)
        model._setup_learn(10 ** 6, callback=callback)
        cb = model._init_callback(callback)
        out = []
        for _ in range(rollouts):
            complete = model.collect_rollouts(venv, cb, model.rollout_buffer, model.n_steps)
            buf = model.rollout_buffer
            out.append({f: np.array(getattr(buf, f)) for f in BUFFER_FIELDS} if complete else None)
            if not complete:
                break
            model.train()
        return out, model.num_timesteps, np.array(model._last_obs), model.overlaps(venv), venv.step
    finally:
        venv.close()


@pytest.mark.parametrize("num_cpus", [1, 2])
def test_same_rollouts_bit_for_bit_as_sb3s_loop(tmp_path, num_cpus):
    plain, t_plain, last_plain, overlapped_plain, _ = _rollouts(tmp_path / "a", num_cpus, overlap=False)
    ours, t_ours, last_ours, overlapped_ours, _ = _rollouts(tmp_path / "b", num_cpus, overlap=True)
    assert not overlapped_plain and overlapped_ours
    assert t_plain == t_ours and np.array_equal(last_plain, last_ours)
    for a, b in zip(plain, ours):
        for f in BUFFER_FIELDS:
            assert np.array_equal(a[f], b[f]), f
    first = plain[0]
    assert (first["episode_starts"][1:] > 0).any()  # cars ended inside the rollout ...
    assert not np.array_equal(plain[0]["observations"], plain[1]["observations"])  # ... and it went on


def test_training_overlapped_gives_the_same_weights(tmp_path):
    for overlap in (False, True):
        train(tiny_train_config(num_cpus=2, overlap=overlap, device="cpu"), tmp_path / str(overlap))
    assert same_checkpoint_weights(tmp_path / "False", tmp_path / "True")


class _StopAt(BaseCallback):
    def __init__(self, step: int) -> None:
        super().__init__()
        self.step, self.seen = step, 0

    def _on_step(self) -> bool:
        self.seen += 1
        return self.seen < self.step


def test_a_stop_mid_rollout_leaves_no_step_in_flight(tmp_path):
    out, timesteps, _, overlapped, step = _rollouts(tmp_path, 2, overlap=True, callback=_StopAt(4))
    assert overlapped and out == [None]
    assert timesteps == 4 * 9  # four steps of 3 instances x 3 cars reached the callback


def test_a_stopped_overlapped_env_still_steps(tmp_path):
    cfg = _config(2, True)
    venv = make_vec_env(cfg)
    try:
        model = build_model(cfg, venv)
        model.set_logger(configure(str(tmp_path), []))
        venv.seed(0)
        model._setup_learn(10 ** 6, callback=_StopAt(2))
        cb = model._init_callback(_StopAt(2))
        assert model.collect_rollouts(venv, cb, model.rollout_buffer, model.n_steps) is False
        obs, rewards, dones, infos = venv.step(np.zeros(venv.num_envs, dtype=np.int64))  # answers at once
        assert obs.shape[0] == venv.num_envs
    finally:
        venv.close()


def test_without_workers_sb3s_own_loop_runs(tmp_path, monkeypatch):
    from stable_baselines3 import PPO

    calls = []
    original = PPO.collect_rollouts

    def spy(self, *args, **kwargs):
        calls.append(1)
        return original(self, *args, **kwargs)

    monkeypatch.setattr(PPO, "collect_rollouts", spy)
    _, _, _, overlapped, _ = _rollouts(tmp_path, 0, overlap=True, rollouts=1)
    assert not overlapped and calls == [1]


def test_the_update_runs_on_its_own_threads_and_a_new_model_starts_from_the_same_weights():
    """By default the update takes every core and rollouts the cores the workers leave free; the
    thread count an update leaves set must not change the next model's initial (orthogonal) weights."""
    import os

    from training.trainers.trainer import TrainConfig

    cfg = TrainConfig(env_overrides={"num_cars": 2, "horizon": 5}, n_envs=2, batch_decisions=40, minibatch=20,
                      epochs=1, num_cpus=1, device="cpu")
    first = []
    for left_set in (1, 2):
        th.set_num_threads(left_set)
        venv = make_vec_env(cfg)
        try:
            model = build_model(cfg, venv)
            assert (model.rollout_threads, model.update_threads) == (max(1, (os.cpu_count() or 1) - 1),
                                                                    os.cpu_count() or 1)
            first.append([p.detach().clone() for p in model.policy.parameters()])
        finally:
            venv.close()
    assert all(th.equal(a, b) for a, b in zip(*first))
