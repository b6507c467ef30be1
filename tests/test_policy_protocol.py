"""One interface for everything that drives cars, and one path resolution for both loaders."""

from __future__ import annotations

import numpy as np
import pytest

import box2d_driving
from box2d_driving.policies import SCRIPTED, CheckpointError, NumpyPolicy, Policy, load_trained, make_policy


@pytest.mark.parametrize("name", sorted(SCRIPTED))
def test_every_scripted_driver_is_a_policy(name):
    env = box2d_driving.make("crosswalk-v0" if name == "pedestrian-oracle" else "intersection-v0")
    policy = make_policy(name, env, seed=0)
    assert isinstance(policy, Policy)
    obs, _ = env.reset(seed=0)
    actions = policy.act({a: obs[a] for a in env.agents})
    assert set(actions) == set(env.agents) and all(isinstance(int(v), int) for v in actions.values())
    env.close()


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
