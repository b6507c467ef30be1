"""Crosswalk: pedestrian facts in infos, invisible-pedestrian control, crosswalk metrics."""

import math

import numpy as np
import pytest

import box2d_driving
from box2d_driving.config import ConfigError
from box2d_driving.metrics.pedestrians import crosswalk_metrics, stopping_distance
from box2d_driving.metrics.rollouts import COLLIDED_WITH, COLUMNS, OPTIONAL_COLUMNS


def test_pedestrian_facts_in_infos():
    env = box2d_driving.make("crosswalk-v0", num_cars=2, pedestrians_range=(3, 3))
    _, infos = env.reset(seed=2)
    cfg = env.config
    for i, info in infos.items():
        k = int(i.split("_")[1])
        front = env.world.positions[k, 0] + cfg.car_length / 2
        assert info["crosswalk_distance"] == pytest.approx(cfg.crosswalk_x[0] - front)
        rel = env.world.ped_positions - env.world.positions[k]
        ahead = np.abs(np.arctan2(rel[:, 1], rel[:, 0])) <= math.pi / 6
        d = np.linalg.norm(rel, axis=1)[ahead]
        expected = d.min() if len(d) else None
        assert info["pedestrian_distance"] == (pytest.approx(expected) if expected else None)


@pytest.mark.parametrize("backend", ["numba", "box2d"])
def test_invisible_pedestrians_are_not_seen_but_still_solid(backend):
    seen = box2d_driving.make("crosswalk-v0", num_cars=1, lidar_backend=backend)
    blind = box2d_driving.make("crosswalk-v0", num_cars=1, lidar_backend=backend,
                               lidar_sees_pedestrians=False)
    seen.reset(seed=0)
    blind.reset(seed=0)
    a = seen._lidar_distances(np.array([0]))
    b = blind._lidar_distances(np.array([0]))
    assert np.sum(np.isfinite(a)) > np.sum(np.isfinite(b))  # some rays hit pedestrians
    assert np.all(b[np.isfinite(b)] >= a[np.isfinite(b)] - 1e-9)


def _table(samples):
    """samples: (episode, car, decision, speed, ped_distance, arrived, collided, with)."""
    n = len(samples)
    t = {c: np.zeros(n) for c in COLUMNS + OPTIONAL_COLUMNS}
    ep, car, dec, v, d, arr, col, wth = map(np.array, zip(*samples))
    t.update(episode=ep.astype(int), car=car.astype(int), decision=dec.astype(int), speed=v,
             pedestrian_distance=d.astype(float), arrived=arr.astype(bool), collided=col.astype(bool),
             collided_with=np.array([COLLIDED_WITH.index(w) for w in wth]),
             crosswalk_distance=np.full(n, 5.0))
    return t


def test_crosswalk_metrics_on_hand_built_samples():
    a = 3.0
    rows = [
        (0, 0, 0, 0.0, 30.0, 0, 0, ""),        # decision 0: not a sample
        (0, 0, 1, 6.0, 6.0, 0, 0, ""),         # 6 m/s needs 6 m: safe (boundary)
        (0, 0, 2, 6.0, 5.9, 0, 0, ""),         # unsafe
        (0, 0, 3, 2.0, np.nan, 1, 0, ""),      # arrived, no pedestrian ahead
        (0, 1, 1, 10.0, 20.0, 0, 0, ""),       # safe (16.7 m needed)
        (0, 1, 2, 10.0, 1.0, 0, 1, "pedestrian"),  # collided row: not a sample
    ]
    m = crosswalk_metrics(_table(rows), a)
    assert stopping_distance(6.0, a) == pytest.approx(6.0)
    assert m["samples_with_pedestrian_ahead"] == 3
    assert m["safe_stopping_share"] == pytest.approx(2 / 3)
    assert m["pedestrian_collision_rate"] == pytest.approx(0.5)
    assert m["success_rate"] == pytest.approx(0.5)
    assert m["pedestrian_distance_mean"] == pytest.approx((6.0 + 5.9 + 20.0) / 3)


@pytest.mark.parametrize("turn_back", [False, True])
def test_pedestrians_cross_once_or_walk_back(turn_back):
    """Crossing once: a pedestrian walks at its speed until past the far walkway (checked once
    per decision), then stands there; with turn_back it reverses instead."""
    env = box2d_driving.make("crosswalk-v0", num_cars=1, pedestrians_range=(1, 1),
                             pedestrians_turn_back=turn_back, horizon=30)
    env.reset(seed=3)
    w, cfg = env.world, env.config
    y_max = cfg.road_width / 2 + cfg.walkway
    vy = w.ped_velocity[0, 1]
    y0 = w.ped_positions[0, 1]
    far = y_max if vy > 0 else -y_max
    t_cross = (far - y0) / vy  # seconds until it leaves its bounds
    decisions = int(math.ceil(t_cross / cfg.decision_time)) + 2
    for _ in range(decisions):
        w.advance(np.zeros(1))  # hold the car still; only the pedestrian matters here
    y = w.ped_positions[0, 1]
    if turn_back:
        assert w.ped_velocity[0, 1] == pytest.approx(-vy)
        assert abs(y) <= y_max + abs(vy) * cfg.decision_time
    else:
        assert w.ped_velocity[0, 1] == 0.0
        assert y_max <= abs(y) <= y_max + abs(vy) * cfg.decision_time
        assert np.sign(y) == np.sign(vy)


def test_pedestrian_oracle_never_hits_a_pedestrian_where_full_throttle_does():
    """The crosswalk is solvable: the privileged oracle crosses without hitting anyone on
    episodes where driving blind at full throttle hits pedestrians."""
    from box2d_driving.metrics.rollouts import run_episodes
    from box2d_driving.policies import FullThrottlePolicy, PedestrianOraclePolicy

    env = box2d_driving.make("crosswalk-v0", num_cars=1)
    oracle = crosswalk_metrics(run_episodes(env, PedestrianOraclePolicy(env), 25, seed=2000), 3.0)
    blind = crosswalk_metrics(run_episodes(env, FullThrottlePolicy(env), 25, seed=2000), 3.0)
    assert blind["pedestrian_collision_rate"] > 0.1
    assert oracle["pedestrian_collision_rate"] == 0.0
    assert oracle["success_rate"] >= 0.9
    assert oracle["safe_stopping_share"] > blind["safe_stopping_share"]


def test_crosswalk_ahead_in_the_satnav_rises_to_one_then_drops_to_zero():
    env = box2d_driving.make("crosswalk-v0", num_cars=1, crosswalk_in_satnav=True, pedestrians_range=(0, 0))
    lay = env.observation_layout
    assert "crosswalk_ahead" in lay.satnav_fields
    assert box2d_driving.make("crosswalk-v0").observation_layout.satnav_fields[-1] == "inv_goal_distance"
    cfg = env.config
    obs, infos = env.reset(seed=0)
    values, distances = [], []
    while env.agents:
        _, satnav = lay.split(obs["car_0"])
        values.append(float(satnav[-1, lay.field("crosswalk_ahead")]))
        distances.append(infos["car_0"]["crosswalk_distance"])
        obs, _, _, _, infos = env.step({"car_0": len(cfg.accelerations) - 1})
    values, distances = np.array(values), np.array(distances)
    far = distances > cfg.crosswalk_view
    assert np.all(values[far] == 0.0)
    near = (distances > 0) & ~far
    np.testing.assert_allclose(values[near], 1.0 - distances[near] / cfg.crosswalk_view, atol=1e-6)
    past = distances < -(cfg.crosswalk_x[1] - cfg.crosswalk_x[0]) - cfg.car_length
    assert past.any() and np.all(values[past] == 0.0)
    with pytest.raises(ConfigError, match="crosswalk_view"):
        box2d_driving.make("crosswalk-v0", crosswalk_view=0.0)
