"""Shipped policies run with numpy alone: the same actions as the torch actor on 10,000 recorded
observations of each, the same spline choices for the bilevel ones, and the single-agent envs drive
their background cars with them where torch and the trainer cannot be imported."""

from __future__ import annotations

import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest

from box2d_driving.policies import CheckpointError, load_trained
from box2d_driving.policies.numpy_actor import adaptive_average, circular_conv
from tests.helpers import HANG

ROOT = Path(__file__).resolve().parent.parent
# every shipped policy: a run folder with its checkpoint (nested ones too, such as the
# communication policy), or a bilevel run folder (accel/ + spline/)
SHIPPED = sorted({f.parent.parent if f.parent.name in ("accel", "spline") else f.parent
                  for f in (ROOT / "assets" / "policies").rglob("model.safetensors")})
RECORDED = 10_000


def _record(policy, n_obs: int, seed: int) -> np.ndarray:
    """``n_obs`` observations of the policy's own env, driven by the policy with a fifth of the
    actions drawn at random (so that states off the policy's own path are in the sample too)."""
    env = policy.make_env()
    rng = np.random.default_rng(seed)
    rows, episode = [], 0
    while sum(len(r) for r in rows) < n_obs:
        obs, _ = env.reset(seed=seed + episode)
        episode += 1
        while env.agents:
            rows.append(np.stack(list(obs.values())))
            actions = policy.act(obs)
            n = env.action_space(env.agents[0]).n
            actions = {a: (int(rng.integers(n)) if rng.random() < 0.2 else act) for a, act in actions.items()}
            obs, *_ = env.step(actions)
            obs = {a: o for a, o in obs.items() if a in env.agents}  # the finished cars' last views go
    env.close()
    return np.concatenate(rows)[:n_obs]


@pytest.mark.parametrize("run", SHIPPED, ids=lambda p: str(p.relative_to(ROOT / "assets" / "policies")))
def test_numpy_actor_equals_the_torch_actor_on_recorded_observations(run):
    pytest.importorskip("torch")
    from training.runs.inference import actor_actions, load_policy

    mine, theirs = load_trained(run), load_policy(run)
    assert (mine.env_id, mine.env_overrides, mine.stop_value) == (theirs.env_id, theirs.env_overrides,
                                                                    theirs.stop_value)
    obs = _record(mine, RECORDED, seed=7)
    assert obs.shape == (RECORDED, mine.obs_dim)
    expected = actor_actions(theirs.policy, obs)
    got = mine.actions(obs)
    assert np.array_equal(got, expected), f"{int((got != expected).sum())} of {len(obs)} actions differ"
    if theirs.spline_policy is not None:  # the bilevel runs' path choice too
        env = mine.make_env()
        obs0 = np.concatenate([np.stack(list(env.plan(seed).values())) for seed in range(200)])
        got, expected = mine.spline_policy(obs0), theirs.choose_paths(obs0)
        if got.dtype.kind == "f":  # a continuous path choice (fast lanes): equal within float32 rounding
            np.testing.assert_allclose(got, expected, rtol=1e-5, atol=1e-6)
        else:
            assert np.array_equal(got, expected)


def test_sampling_follows_the_policy_distribution_and_is_seeded():
    run = ROOT / "assets" / "policies" / "traffic_lights_4cars_noise05"
    greedy = load_trained(run)
    obs = _record(greedy, 200, seed=3)
    a = load_trained(run, deterministic=False, seed=1).actions(np.repeat(obs[:1], 20_000, axis=0))
    b = load_trained(run, deterministic=False, seed=1).actions(np.repeat(obs[:1], 20_000, axis=0))
    assert np.array_equal(a, b)
    logits = greedy.actor.logits(obs[:1])[0]
    p = np.exp(logits - logits.max())
    p /= p.sum()
    freq = np.bincount(a, minlength=len(p)) / len(a)
    assert np.abs(freq - p).max() < 0.02


def test_the_numpy_layers_agree_with_their_definitions():
    rng = np.random.default_rng(0)
    x = rng.normal(size=(3, 2, 12)).astype(np.float32)
    w = rng.normal(size=(4, 2, 5)).astype(np.float32)
    b = rng.normal(size=4).astype(np.float32)
    out = circular_conv(x, w, b)
    for o in range(4):
        for r in range(12):  # cross-correlation over the ring: index r + j - 2 wraps
            want = b[o] + sum(w[o, c, j] * x[:, c, (r + j - 2) % 12] for c in range(2) for j in range(5))
            np.testing.assert_allclose(out[:, o, r], want, rtol=1e-5, atol=1e-5)
    pool = adaptive_average(10, 4)  # torch's bins for 10 -> 4: [0,3) [2,5) [5,8) [7,10)
    np.testing.assert_allclose(pool.sum(axis=0), 1.0)
    assert [tuple(np.flatnonzero(pool[:, i])) for i in range(4)] == [(0, 1, 2), (2, 3, 4), (5, 6, 7), (7, 8, 9)]


def test_numpy_actor_reads_a_policy_with_the_paper_codes_encoder(tmp_path):
    """A run trained with ``lidar_encoder="original"`` acts the same through numpy as through
    torch, and its strided convolution is torch's."""
    th = pytest.importorskip("torch")
    from training.runs.inference import actor_actions, load_policy
    from training.trainers.trainer import train
    from box2d_driving.policies.numpy_actor import strided_circular_conv
    from tests.helpers import tiny_train_config

    train(tiny_train_config(lidar_encoder="original"), tmp_path / "run")
    mine, theirs = load_trained(tmp_path / "run"), load_policy(tmp_path / "run")
    assert mine.actor.original
    obs = _record(mine, 2_000, seed=5)
    assert np.array_equal(mine.actions(obs), actor_actions(theirs.policy, obs))
    logits = mine.actor.logits(obs[:300])
    with th.no_grad():
        want = theirs.policy.action_net(theirs.policy.mlp_extractor.forward_actor(th.as_tensor(obs[:300])))
    np.testing.assert_allclose(logits, want.numpy(), rtol=1e-4, atol=1e-5)
    rng = np.random.default_rng(1)
    x, w, b = (rng.normal(size=s).astype(np.float32) for s in ((3, 5, 100), (2, 5, 4), (2,)))
    conv = th.nn.Conv1d(5, 2, 4, 2, 2, padding_mode="circular")
    conv.load_state_dict({"weight": th.as_tensor(w), "bias": th.as_tensor(b)})
    with th.no_grad():
        np.testing.assert_allclose(strided_circular_conv(x, w, b, 2, 2), conv(th.as_tensor(x)).numpy(),
                                   rtol=1e-5, atol=1e-5)


def test_bad_checkpoints_are_refused_with_our_error(tmp_path):
    (tmp_path / "model.zip").write_bytes(b"PK\x03\x04 pickled")
    with pytest.raises(CheckpointError, match="pickled"):
        load_trained(tmp_path)
    (tmp_path / "model.safetensors").write_bytes(b"\x00" * 4)
    with pytest.raises(CheckpointError, match="too short"):
        load_trained(tmp_path)
    with pytest.raises(CheckpointError, match="no checkpoint"):
        load_trained(tmp_path / "missing")


def test_single_agent_envs_use_the_shipped_policy_without_torch_or_the_trainer():
    """The base install: torch, SB3 and the training package cannot be imported at all."""
    script = textwrap.dedent("""
        import sys
        class Block:
            def find_spec(self, name, path=None, target=None):
                if name.split(".")[0] in ("torch", "stable_baselines3", "supersuit", "training"):
                    raise ImportError(f"blocked: {name}")
        sys.meta_path.insert(0, Block())
        import gymnasium as gym
        import box2d_driving
        for gym_id in ("box2d_driving/Intersection-v0", "box2d_driving/Crosswalk-v0"):
            env = gym.make(gym_id).unwrapped
            assert env.background_name.startswith("shipped:"), env.background_name
            env.reset(seed=0)
            for _ in range(5):
                env.step(env.action_space.sample())
        print("ok", sorted(m for m in sys.modules if m.split(".")[0] in ("torch", "training")))
    """)
    out = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, cwd=ROOT, timeout=HANG)
    assert out.returncode == 0, out.stderr[-2000:]
    assert out.stdout.strip().endswith("ok []")
