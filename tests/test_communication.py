"""The 1-bit communication channel."""

import numpy as np

from tests.helpers import hand_env, straight_car


def _env(cars):
    return hand_env(cars, communication=True, horizon=10)


def test_unheard_messages_are_sent_but_received_as_zero():
    cars = [straight_car((0, 0), (100, 0)), straight_car((20, 0), (100, 0))]
    received = {}
    for heard in (True, False):
        env = hand_env(cars, communication=True, horizon=10, messages_heard=heard)
        env.reset(seed=0)
        n = len(env.config.accelerations)
        zero = int(np.argmin(np.abs(env.config.accelerations)))
        obs, _, _, _, info = env.step({"car_0": zero, "car_1": zero + n})
        lay = env.observation_layout
        assert info["car_1"]["bit_sent"] == 1
        received[heard] = (info["car_0"]["bit_received"], lay.split(obs["car_0"])[1][-1, lay.field("bit_received")])
    assert received[True] == (1, 1.0)
    assert received[False] == (0, 0.0)


def test_receives_bit_of_nearest_car_ahead_within_range_and_angle():
    cars = [
        straight_car((0, 0), (100, 0)),     # car_0: listener
        straight_car((20, 0), (100, 0)),    # car_1: 20 m straight ahead
        straight_car((10, 10), (100, 10)),  # car_2: 45 degrees off: not heard
    ]
    env = _env(cars)
    obs, info = env.reset(seed=0)
    n = len(env.config.accelerations)
    zero = int(np.argmin(np.abs(env.config.accelerations)))
    lay = env.observation_layout
    _, _, _, _, info = env.step({"car_0": zero, "car_1": zero + n, "car_2": zero + n})
    assert info["car_1"]["bit_sent"] == 1 and info["car_0"]["bit_sent"] == 0
    assert info["car_0"]["bit_received"] == 1
    assert info["car_1"]["bit_received"] == 0  # car_0 is behind it
    obs, _, _, _, info = env.step({"car_0": zero + n, "car_1": zero, "car_2": zero + n})
    _, satnav = lay.split(obs["car_0"])
    assert satnav[-1, lay.field("bit_received")] == 0.0  # car_1 now sends 0
    assert info["car_0"]["bit_received"] == 0  # never its own bit


def test_nearest_sender_wins_and_range_is_respected():
    cars = [
        straight_car((0, 0), (100, 0)),
        straight_car((20, 0), (100, 0)),    # sends 1, 20 m
        straight_car((15, 2), (100, 2)),    # sends 0, nearer (15.1 m, 7.6 degrees)
        straight_car((-35, 0), (100, 0)),   # behind car_0
    ]
    env = _env(cars)
    env.reset(seed=0)
    n = len(env.config.accelerations)
    zero = int(np.argmin(np.abs(env.config.accelerations)))
    _, _, _, _, info = env.step({"car_0": zero, "car_1": zero + n, "car_2": zero, "car_3": zero})
    assert info["car_0"]["bit_received"] == 0
    # car_3 hears car_0 (35 m away: out of range) -> nothing
    _, _, _, _, info = env.step({"car_0": zero + n, "car_1": zero, "car_2": zero, "car_3": zero})
    assert info["car_3"]["bit_received"] == 0
    cars[3] = straight_car((-25, 0), (100, 0))
    env = _env(cars)
    env.reset(seed=0)
    _, _, _, _, info = env.step({"car_0": zero + n, "car_1": zero, "car_2": zero, "car_3": zero})
    assert info["car_3"]["bit_received"] == 1


def test_own_bit_fallback_is_a_memory_only_for_a_car_that_hears_nobody():
    import pytest

    import box2d_driving

    cars = [straight_car((0, 0), (100, 0)), straight_car((20, 0), (100, 0))]  # car_1 ahead of car_0
    got = {}
    for fallback in ("zero", "own"):
        env = hand_env(cars, communication=True, horizon=10, comm_fallback=fallback)
        env.reset(seed=0)
        n = len(env.config.accelerations)
        zero = int(np.argmin(np.abs(env.config.accelerations)))
        _, _, _, _, info = env.step({"car_0": zero + n, "car_1": zero + n})
        first = (info["car_0"]["bit_received"], info["car_1"]["bit_received"])
        _, _, _, _, info = env.step({"car_0": zero + n, "car_1": zero})
        got[fallback] = first + (info["car_0"]["bit_received"], info["car_1"]["bit_received"])
    # car_0 always hears car_1 (never itself); car_1 hears nobody: 0, or its own last bit (1, then 0)
    assert got["zero"] == (1, 0, 0, 0)
    assert got["own"] == (1, 1, 0, 0)
    with pytest.raises(box2d_driving.ConfigError, match="comm_fallback"):
        box2d_driving.make("real-junction-v0", communication=True, comm_fallback="self")
