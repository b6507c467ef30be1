"""One interface for everything that drives cars, and one path resolution for both loaders."""

from __future__ import annotations

import numpy as np
import pytest

import box2d_driving
from box2d_driving.policies import (SCRIPTED, CheckpointError, ConstantSpeedPolicy, NumpyPolicy, Policy, load_trained,
                                    make_policy)


@pytest.mark.parametrize("name", sorted(SCRIPTED))
def test_every_scripted_driver_is_a_policy(name):
    env = box2d_driving.make("crosswalk-v0" if name == "pedestrian-oracle" else "intersection-v0")
    policy = make_policy(name, env, seed=0)
    assert isinstance(policy, Policy)
    obs, _ = env.reset(seed=0)
    actions = policy.act({a: obs[a] for a in env.agents})
    assert set(actions) == set(env.agents) and all(isinstance(int(v), int) for v in actions.values())
    env.close()


def test_the_constant_speed_driver_reaches_half_the_limit_and_holds_it():
    """A lone car from a standstill (exact integration, 1 s decisions, levels 0.25 m/s^2 apart):
    +1.5, +1.5, +1.0 m/s^2 to 4 m/s, then level 0 until it arrives; on a quarter of the limit
    it settles at 2 m/s."""
    for fraction, expected in ((0.5, [0.0, 1.5, 3.0, 4.0, 4.0, 4.0]), (0.25, [0.0, 1.5, 2.0, 2.0, 2.0, 2.0])):
        env = box2d_driving.make("intersection-v0", num_cars=1)
        policy = ConstantSpeedPolicy(env, fraction=fraction)
        obs, infos = env.reset(seed=3)
        speeds = [infos["car_0"]["speed"]]
        while env.agents and len(speeds) < len(expected):
            obs, _, _, _, infos = env.step(policy.act(obs))
            speeds.append(infos["car_0"]["speed"])
        assert speeds == pytest.approx(expected, abs=1e-9)
        env.close()
    with pytest.raises(ValueError, match="fraction"):
        ConstantSpeedPolicy(box2d_driving.make("intersection-v0"), fraction=1.5)


def test_both_loaders_give_policies_from_the_same_names_with_the_same_actions():
    from training.runs.inference import TorchPolicy, load_policy

    name = "traffic_lights_4cars_noise05"  # a shipped policy by name: both loaders resolve it alike
    numpy_policy, torch_policy = load_trained(name), load_policy(name)
    assert isinstance(numpy_policy, NumpyPolicy) and isinstance(torch_policy, TorchPolicy)
    assert isinstance(numpy_policy, Policy) and isinstance(torch_policy, Policy)
    assert not isinstance(object(), Policy)
    env = numpy_policy.make_env()
    obs, _ = env.reset(seed=1_500_000_000)
    batch = np.stack([obs[a] for a in env.agents])
    assert np.array_equal(numpy_policy.actions(batch), torch_policy.actions(batch))
    env.close()


def test_a_folder_of_policies_is_refused_alike_by_both_loaders(tmp_path):
    import shutil

    from box2d_driving.policies.shipped import SHIPPED_POLICIES_DIR
    from training.runs.inference import load_policy

    shutil.copytree(SHIPPED_POLICIES_DIR / "traffic_lights_4cars", tmp_path / "both" / "a")
    shutil.copytree(SHIPPED_POLICIES_DIR / "traffic_lights_4cars", tmp_path / "both" / "b")
    messages = []
    for loader in (load_trained, load_policy):
        with pytest.raises(CheckpointError) as caught:
            loader(tmp_path / "both")
        messages.append(str(caught.value))
    assert messages[0] == messages[1] and "2 in sub-folders (a, b)" in messages[0]


def test_the_earlier_class_names_still_import():
    from box2d_driving.policies import TrainedPolicy
    from training.runs.inference import TorchPolicy
    from training.runs.inference import TrainedPolicy as TorchTrainedPolicy

    assert TrainedPolicy is NumpyPolicy and TorchTrainedPolicy is TorchPolicy
