"""Reward terms on hand-built situations, and their per-episode bounds."""

import numpy as np
import pytest

import box2d_driving
from box2d_driving.envs.reward import TERMS
from box2d_driving.registry import registry
from tests.helpers import hand_env, level_index, straight_car


def test_first_decision_terms_exact():
    env = hand_env([straight_car((0, 0), (100, 0))], horizon=10)
    env.reset(seed=0)
    _, rew, _, _, info = env.step({"car_0": level_index(env, 1.5)})
    t = info["car_0"]["reward_terms"]
    assert t["goal"] == 0.0 and t["collision"] == 0.0
    assert t["smoothness"] == pytest.approx(-(1 / 10) * 1.5 / 3.0)
    assert t["progress"] == pytest.approx(-(1 / 10) * (100 - 0.75) / 100)
    assert rew["car_0"] == pytest.approx(sum(t.values()))
    _, _, _, _, info = env.step({"car_0": level_index(env, -0.5)})
    assert info["car_0"]["reward_terms"]["smoothness"] == pytest.approx(-(1 / 10) * 2.0 / 3.0)


def test_goal_reward_on_arrival_decision():
    env = hand_env([straight_car((0, 0), (5, 0))], horizon=10)
    env.reset(seed=0)
    up = level_index(env, 1.5)
    for t in range(1, 4):
        _, rew, term, _, info = env.step({"car_0": up})
        # s = 0.75 t^2: 0.75, 3.0, 6.75 -> arrives on decision 3
        assert term["car_0"] == (t == 3)
    terms = info["car_0"]["reward_terms"]
    assert terms["goal"] == 1.0 and terms["progress"] == 0.0 and terms["collision"] == 0.0
    assert env.agents == []


def test_collision_pays_the_remaining_progress_penalty():
    h = 20
    env = hand_env([straight_car((-15, 0), (100, 0)), straight_car((15, 0), (-100, 0))], horizon=h)
    env.reset(seed=0)
    up = level_index(env, 1.5)
    for t in range(1, h):
        _, rew, term, _, info = env.step({a: up for a in env.agents})
        if any(term.values()):
            break
    for a in ("car_0", "car_1"):
        terms = info[a]["reward_terms"]
        d = info[a]["distance_to_goal"]
        assert terms["collision"] == -1.0
        assert terms["progress"] == pytest.approx(-(1 / h) * (d / 115.0) * (h - t + 1))
    assert rew["car_0"] == pytest.approx(rew["car_1"])


def test_truncation_at_horizon_not_termination():
    env = hand_env([straight_car((0, 0), (500, 0))], horizon=3)
    env.reset(seed=0)
    for t in range(3):
        _, _, term, trunc, _ = env.step({"car_0": level_index(env, 0.0)})
    assert trunc == {"car_0": True} and term == {"car_0": False}
    assert env.agents == []


@pytest.mark.parametrize("env_id", sorted(registry()))
def test_every_term_sum_is_within_unit_bound_over_50_random_episodes(env_id):
    env = box2d_driving.make(env_id)
    rng = np.random.default_rng(0)
    worst = {t: 0.0 for t in TERMS}
    for ep in range(50):
        env.reset(seed=ep)
        sums = {a: {t: 0.0 for t in TERMS} for a in env.agents}
        while env.agents:
            acts = {a: int(rng.integers(env.action_space(a).n)) for a in env.agents}
            _, rew, _, _, info = env.step(acts)
            for a, i in info.items():
                for t in TERMS:
                    sums[a][t] += i["reward_terms"][t]
                assert rew[a] == pytest.approx(sum(i["reward_terms"].values()))
        for s in sums.values():
            for t in TERMS:
                assert -1.0 - 1e-9 <= s[t] <= 1.0 + 1e-9, (t, s[t])
                worst[t] = min(worst[t], s[t])
    assert worst["progress"] < -0.2  # the bound is exercised, not vacuous


def test_reward_terms_are_the_docstring_formulas_to_the_bit():
    from box2d_driving.envs.reward import reward_terms

    rng = np.random.default_rng(11)
    n, h = 500, 200
    arrived, collided = rng.random(n) < 0.2, rng.random(n) < 0.2
    level, prev = rng.choice([-3.0, -1.5, 0.0, 0.75, 1.5], n), rng.choice([-3.0, 0.0, 1.5], n)
    initial = rng.uniform(10, 120, n)
    remaining, decision = initial * rng.random(n), rng.integers(1, h + 1, n)
    got = reward_terms(arrived=arrived, collided=collided, accel_level=level, prev_accel_level=prev,
                       accel_range=4.5, remaining=remaining, initial=initial, decision=decision, horizon=h,
                       goal_reward=1.0, collision_reward=-1.0)
    want = {"goal": np.where(arrived, 1.0, 0.0), "collision": np.where(collided, -1.0, 0.0),
            "smoothness": -np.abs(level - prev) / 4.5 / h,
            "progress": -(remaining / initial) * np.where(collided, h - decision + 1, 1) / h}
    assert list(got) == list(TERMS)
    for term in TERMS:
        assert got[term].tobytes() == want[term].tobytes(), term
    one = reward_terms(arrived=arrived, collided=collided, accel_level=level, prev_accel_level=prev,
                       accel_range=4.5, remaining=remaining, initial=initial, decision=7, horizon=h,
                       goal_reward=1.0, collision_reward=-1.0)  # one decision for every car
    expected = (-(remaining / initial) * (h - 6) / h)[collided]
    assert one["progress"][collided].tolist() == pytest.approx(expected.tolist())
