"""PettingZoo / Gymnasium contract of every registered env."""

import pickle

import numpy as np
import pytest
from pettingzoo.test import api_test, parallel_api_test, parallel_seed_test

import box2d_driving
from box2d_driving import ConfigError
import importlib

from box2d_driving.scenarios import scenario

ENV_IDS = sorted(box2d_driving.registry())
VARIANTS = [(e, {}) for e in ENV_IDS] + [("intersection-v0", {"communication": True, "lidar_noise": 0.5}),
                                         ("intersection-v0", {"preset": "paper", "lidar_noise": 0.25}),
                                         ("intersection-v0", {"turns": True, "preset": "paper"})]


@pytest.mark.parametrize("env_id,overrides", VARIANTS)
def test_parallel_api(env_id, overrides):
    parallel_api_test(box2d_driving.make(env_id, **overrides), num_cycles=60)


@pytest.mark.parametrize("env_id,overrides", VARIANTS)
def test_parallel_seed(env_id, overrides):
    parallel_seed_test(lambda: box2d_driving.make(env_id, **overrides), num_cycles=40)


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_aec_api(env_id):
    import warnings

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        api_test(scenario(env_id).aec_env(), num_cycles=30)
    assert not [w for w in caught if "infinity" in str(w.message)]  # finite observation bounds
    from pettingzoo.utils.env import AECEnv

    module = importlib.import_module("box2d_driving.envs." + env_id.replace("-", "_"))  # PettingZoo-style
    for make in (module.env, module.raw_env):
        assert isinstance(make(), AECEnv), make  # env() and raw_env() are AEC envs
    assert isinstance(module.parallel_env(num_cars=2), scenario(env_id).env_class)


@pytest.mark.parametrize("env_id,overrides", VARIANTS + [("intersection-v0", {"lidar_encoding": "proximity"})])
def test_every_observation_lies_in_its_finite_space(env_id, overrides):
    env = box2d_driving.make(env_id, **overrides)
    space = env.observation_space(env.possible_agents[0])
    assert np.isfinite(space.low).all() and np.isfinite(space.high).all()
    for seed in range(3):
        obs, _ = env.reset(seed=seed)
        while env.agents:
            assert all(space.contains(o) for o in obs.values()), (seed, env.decision)
            obs, *_ = env.step({a: env.action_space(a).sample() for a in env.agents})


def test_reset_seeds_the_action_spaces():
    def samples(seed):
        env = box2d_driving.make("intersection-v0")
        env.reset(seed=seed)
        return [env.action_space(a).sample() for a in env.agents for _ in range(5)]

    assert samples(3) == samples(3) and samples(3) != samples(4)


def test_the_inverse_lidar_encoding_is_bounded():
    from box2d_driving.sensors.readout import MIN_DISTANCE, encode

    values = encode(np.array([0.0, 1e-9, 0.05, 2.0, np.inf]), 50.0, "inverse")
    assert values.tolist() == pytest.approx([1 / MIN_DISTANCE] * 3 + [0.5, 0.0])


@pytest.mark.parametrize("env_id,overrides", VARIANTS)
def test_same_seed_same_trajectory_bit_for_bit(env_id, overrides):
    def rollout():
        env = box2d_driving.make(env_id, **overrides)
        rng = np.random.default_rng(123)
        obs, _ = env.reset(seed=7)
        frames = [np.stack([obs[a] for a in sorted(obs)])]
        for _ in range(100):
            if not env.agents:
                obs, _ = env.reset()
            else:
                actions = {a: int(rng.integers(env.action_space(a).n)) for a in env.agents}
                obs, *_ = env.step(actions)
            frames.append(np.stack([obs[a] for a in sorted(obs)]) if obs else np.zeros(0))
        return frames

    a, b = rollout(), rollout()
    assert len(a) == len(b)
    for x, y in zip(a, b):
        assert x.tobytes() == y.tobytes()


def test_different_seeds_differ():
    env = box2d_driving.make("intersection-v0")
    o1, _ = env.reset(seed=1)
    o2, _ = env.reset(seed=2)
    assert not np.array_equal(o1["car_0"], o2["car_0"])


@pytest.mark.parametrize("env_id", ENV_IDS)
def test_pickle_round_trip(env_id):
    env = box2d_driving.make(env_id, num_cars=3, lidar_noise=0.25)
    clone = pickle.loads(pickle.dumps(env))
    assert clone.config == env.config
    o1, _ = env.reset(seed=3)
    o2, _ = clone.reset(seed=3)
    for a in o1:
        np.testing.assert_array_equal(o1[a], o2[a])


def test_spaces_are_the_same_object_every_call():
    env = box2d_driving.make("intersection-v0", num_cars=4)
    assert env.observation_space("car_0") is env.observation_space("car_3")
    assert env.action_space("car_0") is env.action_space("car_0")
    assert env.action_space("car_0").n == 13
    assert box2d_driving.make("intersection-v0", communication=True).action_space("car_0").n == 26
    assert box2d_driving.make("highway-v0").action_space("car_0").n == 25


def test_observation_layout_is_documented_and_consistent():
    env = box2d_driving.make("highway-v0", num_cars=2, n_rays=40, history=3)
    lay = env.observation_layout
    assert lay.satnav_fields == ("light", "speed", "heading_error", "inv_goal_distance", "rating")
    obs, _ = env.reset(seed=0)
    assert obs["car_0"].shape == (lay.size,) == env.observation_space("car_0").shape
    lidar, satnav = lay.split(obs["car_0"])
    assert lidar.shape == (3, 40) and satnav.shape == (3, 5)
    # at reset the first frame is repeated
    assert np.all(lidar == lidar[0]) and np.all(satnav == satnav[0])
    assert satnav[0, lay.field("light")] == 0.75
    assert 0.5 <= satnav[0, lay.field("rating")] < 1.0


def test_history_is_oldest_first():
    env = box2d_driving.make("intersection-v0", num_cars=1, history=3)
    env.reset(seed=0)
    lay = env.observation_layout
    full = len(env.config.accelerations) - 1
    speeds = []
    for _ in range(3):
        obs, *_ = env.step({"car_0": full})
    _, satnav = lay.split(obs["car_0"])
    speeds = satnav[:, lay.field("speed")]
    assert speeds[0] < speeds[1] < speeds[2]


def test_state_shape_and_space():
    env = box2d_driving.make("intersection-v0", num_cars=4)
    env.reset(seed=0)
    s = env.state()
    assert s.shape == env.state_space.shape and s.dtype == np.float32


def test_registry_and_make_errors():
    ids = box2d_driving.registry()
    assert {"intersection-v0", "highway-v0", "crosswalk-v0"} <= set(ids)
    assert all(isinstance(d, str) and d for d in ids.values())
    with pytest.raises(ConfigError, match="unknown env id 'nope-v0'.*intersection-v0"):
        box2d_driving.make("nope-v0")
    with pytest.raises(ConfigError, match="unknown override.*num_carz.*valid:.*num_cars"):
        box2d_driving.make("intersection-v0", num_carz=3)


@pytest.mark.parametrize("overrides,match", [
    ({"num_cars": -1}, "num_cars"),
    ({"num_cars": 0}, "num_cars"),
    ({"num_cars": 17}, "spawn slots"),
    ({"lidar_noise": 1.5}, "lidar_noise"),
    ({"lidar_noise": -0.1}, "lidar_noise"),
    ({"n_rays": 0}, "n_rays"),
    ({"horizon": 2.5}, "horizon"),
    ({"lidar_backend": "gpu"}, "lidar_backend"),
    ({"v_lim": 30.0}, "physics step"),
    ({"accelerations": (1.0, -1.0)}, "increasing"),
])
def test_invalid_config_is_rejected_with_a_message(overrides, match):
    with pytest.raises(ConfigError, match=match):
        box2d_driving.make("intersection-v0", **overrides)


def test_highway_and_crosswalk_limits():
    with pytest.raises(ConfigError, match="spawn slots"):
        box2d_driving.make("highway-v0", num_cars=13)
    with pytest.raises(ConfigError, match="pedestrians_range"):
        box2d_driving.make("crosswalk-v0", pedestrians_range=(3, 1))


def test_step_rejects_bad_actions():
    from box2d_driving import ActionError

    env = box2d_driving.make("intersection-v0", num_cars=2)
    env.reset(seed=0)
    with pytest.raises(ActionError, match="no action"):
        env.step({"car_0": 0})
    with pytest.raises(ActionError, match=r"car_1 must be in \[0, 13\), got 99"):
        env.step({"car_0": 0, "car_1": 99})
    for bad in (1.7, 3.0, "3", True, np.bool_(True), float("inf"), 2**70, -1, None, [1], np.array([1, 2])):
        with pytest.raises(ActionError, match="car_1"):
            env.step({"car_0": 0, "car_1": bad})
    with pytest.raises(ActionError, match="car_9"):
        env.step({"car_0": 0, "car_1": 0, "car_9": 0})
    with pytest.raises(ActionError, match="dict"):
        env.step([0, 0])
    # numpy integers of any width, and 0-d integer arrays, are actions
    env.step({"car_0": np.int8(3), "car_1": np.array(12, dtype=np.uint16)})
    # an agent that is done may not act again
    env = box2d_driving.make("intersection-v0", num_cars=2, horizon=3)
    env.reset(seed=0)
    while env.agents:
        env.step({a: 0 for a in env.agents})
    with pytest.raises(ActionError, match="reset"):
        env.step({"car_0": 0, "car_1": 0})


def test_infos_carry_metric_facts():
    env = box2d_driving.make("intersection-v0", num_cars=4, communication=True)
    env.reset(seed=0)
    _, _, _, _, infos = env.step({a: 12 for a in env.agents})
    keys = {"position", "heading", "speed", "acceleration", "light", "in_junction", "lane_offset",
            "arrived", "collided", "collided_with", "reward_terms", "distance_to_goal",
            "bit_sent", "bit_received", "stop_line_distance", "collision_partner", "partner_halted"}
    for info in infos.values():
        assert keys <= set(info)
        assert set(info["reward_terms"]) == {"goal", "collision", "smoothness", "progress"}
        assert info["lane_offset"] == pytest.approx(0.5)


@pytest.mark.parametrize("encoding", ["inverse", "proximity"])
def test_lidar_encoding_is_the_whole_array_formula_to_the_bit(encoding):
    from box2d_driving.sensors.readout import MIN_DISTANCE, encode

    rng = np.random.default_rng(5)
    distances = rng.uniform(0.0, 50.0, (40, 32)) * rng.uniform(0, 1, (40, 1)) ** 3
    distances[rng.random((40, 32)) < 0.3] = np.inf
    dropped = rng.random((40, 32)) < 0.25
    gone = dropped | ~np.isfinite(distances)
    expected = np.zeros(distances.shape, dtype=np.float32)  # float64 values rounded once to float32
    if encoding == "inverse":
        expected[~gone] = 1.0 / np.maximum(distances[~gone], MIN_DISTANCE)
    else:
        expected[~gone] = 1.0 - distances[~gone] / 50.0
    got = encode(distances, 50.0, encoding, dropped)
    assert got.dtype == np.float32 and got.tobytes() == expected.tobytes()
    assert encode(distances, 50.0, encoding)[dropped & np.isfinite(distances)].any()  # the mask is optional
    with pytest.raises(ValueError, match="unknown LiDAR encoding"):
        encode(distances, 50.0, "log")
