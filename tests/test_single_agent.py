"""Single-agent Gymnasium envs: Gymnasium's checker, the learner's car is the multi-agent env's
car_0 exactly, backgrounds, seeding, and plain SB3 PPO on them."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import box2d_driving
from box2d_driving import single_agent
from box2d_driving.single_agent import EGO, single_agent_ids

IDS = sorted(single_agent_ids())


@pytest.mark.parametrize("gym_id", IDS)
def test_gymnasium_env_checker_passes(gym_id):
    env = gym.make(gym_id, render_mode="rgb_array")
    check_env(env.unwrapped)
    obs, _ = env.reset(seed=0)
    assert env.observation_space.contains(obs) and env.render().ndim == 3


@pytest.mark.parametrize("gym_id", IDS)
def test_same_seed_same_episode_and_the_episode_ends_with_the_learners_car(gym_id):
    def episode(seed):
        env = gym.make(gym_id)
        obs, _ = env.reset(seed=seed)
        trace, done = [obs], False
        while not done:
            obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
            trace += [obs, reward]
            done = terminated or truncated
        assert info["arrived"] or info["collided"] or truncated
        return trace

    a, b = episode(5), episode(5)
    assert len(a) == len(b) and all(np.array_equal(x, y) for x, y in zip(a, b))


def test_the_learner_is_car_0_of_the_multi_agent_env_exactly():
    from box2d_driving.policies import LightRulePolicy

    env = gym.make("box2d_driving/Intersection-v0", background="rule", num_cars=6).unwrapped
    par = box2d_driving.make("intersection-v0", num_cars=6)
    rule = LightRulePolicy(par)
    obs, _ = env.reset(seed=3)
    pobs, _ = par.reset(seed=3)
    rng = np.random.default_rng(0)
    while True:
        assert np.array_equal(obs, pobs[EGO])
        action = int(rng.integers(env.action_space.n))
        actions = rule.act({a: o for a, o in pobs.items() if a != EGO and a in par.agents})
        actions[EGO] = action
        pobs, prew, pterm, ptrunc, _ = par.step(actions)
        obs, reward, terminated, truncated, _ = env.step(action)
        assert (reward, terminated, truncated) == (prew[EGO], pterm[EGO], ptrunc[EGO])
        if terminated or truncated:
            break
    with pytest.raises(RuntimeError, match="reset"):
        env.step(0)


def test_backgrounds_shipped_scripted_and_without_the_assets_folder(monkeypatch):
    env = gym.make("box2d_driving/Intersection-v0").unwrapped
    assert env.background_name == "shipped:traffic_lights_4cars_noise05"
    assert env.parallel.config.lidar_noise == 0.5  # the settings its policy was trained with
    assert gym.make("box2d_driving/Intersection-v0", num_cars=8).unwrapped.parallel.config.num_cars == 8
    monkeypatch.setattr(single_agent, "SHIPPED", single_agent.SHIPPED / "absent")  # an install without them
    with pytest.warns(UserWarning, match="'traffic_lights_4cars_noise05' is not in .*scripted 'rule' policy"):
        assert gym.make("box2d_driving/Intersection-v0").unwrapped.background_name == "rule"
    with pytest.warns(UserWarning, match="scripted 'pedestrian-oracle'"):
        assert gym.make("box2d_driving/Crosswalk-v0").unwrapped.background_name == "pedestrian-oracle"
    with pytest.raises(ValueError, match="not a scripted policy"):
        gym.make("box2d_driving/Intersection-v0", background="no/such/run")


def test_plain_sb3_ppo_trains_on_it(tmp_path, capsys):
    from training.behaviours import single_agent_ppo

    out = tmp_path / "run"
    assert single_agent_ppo.main(["--quick", "--episodes", "2", "--out", str(out)]) == 0
    assert "success" in capsys.readouterr().out
    from safetensors.torch import load_file

    weights = load_file(str(out / "policy.safetensors"))
    assert any(k.startswith("action_net") for k in weights)
    assert single_agent_ppo.main(["--quick", "--out", str(out)]) == 2  # never overwrites
