"""A rollout's forward pass on a copy of the networks (``rollout_device``): the copy follows every
weight update, so training learns exactly what it learns without it; bad values are refused."""

import pytest

th = pytest.importorskip("torch")
pytest.importorskip("stable_baselines3")

from training.ppo.rollout_copy import RolloutCopy  # noqa: E402
from training.trainers.trainer import ConfigError, build_model, make_vec_env, rollout_device  # noqa: E402
from tests.helpers import tiny_train_config  # noqa: E402


def _trained_weights(config, copy_on: str | None):
    venv = make_vec_env(config)
    try:
        model = build_model(config, venv)
        policy = model.policy
        if copy_on is not None:  # a copy even on the policy's own device: the same path, testable anywhere
            policy.rollout_copy = RolloutCopy(copy_on)
        venv.seed(config.seed)
        model.learn(config.timesteps)
        return {k: v.detach().cpu().clone() for k, v in policy.state_dict().items()}, policy.rollout_copy
    finally:
        venv.close()


def test_rollouts_on_a_copy_learn_exactly_what_the_policy_learns():
    config = tiny_train_config(device="cpu", timesteps=240)  # three updates of 80 decisions
    plain, _ = _trained_weights(config, None)
    copied, copy = _trained_weights(config, "cpu")
    assert copy.refreshes == 3  # once per rollout: every update changed the weights
    assert plain.keys() == copied.keys()
    for name in plain:
        assert th.equal(plain[name], copied[name]), name
    other, _ = _trained_weights(tiny_train_config(device="cpu", timesteps=240, seed=1), "cpu")
    assert any(not th.equal(plain[k], other[k]) for k in plain)  # the comparison above can fail


def test_the_copy_is_refreshed_only_when_a_weight_changed():
    config = tiny_train_config(device="cpu")
    venv = make_vec_env(config)
    try:
        policy = build_model(config, venv).policy
        copy = RolloutCopy("cpu")
        policy.rollout_copy = copy
        policy.set_training_mode(False)
        obs = th.as_tensor(venv.reset())
        with th.no_grad():
            first = policy(obs, deterministic=True)
            policy(obs, deterministic=True)
            assert copy.refreshes == 1
            for p in policy.parameters():
                p.add_(0.5)
            moved = policy(obs, deterministic=True)
        assert copy.refreshes == 2
        assert not th.equal(first[1], moved[1])  # the values follow the new weights
        policy.rollout_copy = None  # the policy's own forward pass gives what the copy gave
        with th.no_grad():
            assert th.equal(policy(obs, deterministic=True)[1], moved[1])
    finally:
        venv.close()


def test_rollout_device_is_checked_and_resolved():
    with pytest.raises(ConfigError, match="rollout_device"):
        tiny_train_config(rollout_device="gpu")
    assert rollout_device(tiny_train_config(device="cpu", rollout_device="cpu")) is None
    assert rollout_device(tiny_train_config(device="cpu")) is None


@pytest.mark.skipif(not th.cuda.is_available(), reason="needs a GPU")
def test_update_on_the_gpu_with_rollouts_on_the_cpu():
    config = tiny_train_config(device="cuda", rollout_device="cpu", timesteps=160)
    assert rollout_device(config) == "cpu"
    venv = make_vec_env(config)
    try:
        model = build_model(config, venv)
        venv.seed(config.seed)
        model.learn(config.timesteps)
        copy = model.policy.rollout_copy
        assert model.policy.device.type == "cuda" and copy is not None and copy.refreshes == 2
        assert next(copy.of(model.policy).parameters()).device.type == "cpu"
    finally:
        venv.close()
