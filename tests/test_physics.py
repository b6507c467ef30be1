"""Physics against analytic answers: kinematics, LiDAR, collisions, tunnelling, pedestrians."""

import math

import numpy as np
import pytest

import box2d_driving
from box2d_driving.physics.kinematics import advance_speed
from box2d_driving.road.geometry import spline_path, wrap_angle
from box2d_driving.road.layout import PedestrianSpawn
from box2d_driving.registry import registry
from tests.helpers import hand_env, level_index, straight_car

BACKENDS = ["numba", "box2d"]


def test_constant_acceleration_matches_analytic_distance_and_speed():
    env = hand_env([straight_car((0, 0), (300, 0))], horizon=30)
    env.reset(seed=0)
    a = 1.5
    for t in range(1, 5):
        _, _, _, _, info = env.step({"car_0": level_index(env, a)})
        i = info["car_0"]
        assert i["speed"] == pytest.approx(a * t, abs=1e-9)
        assert i["position"][0] == pytest.approx(0.5 * a * t * t, abs=1e-3)
        assert i["position"][1] == pytest.approx(0.0, abs=1e-4)


def test_speed_is_clipped_at_v_lim_and_at_zero():
    env = hand_env([straight_car((0, 0), (300, 0))], horizon=30)
    env.reset(seed=0)
    a, v = 1.5, env.config.v_lim
    for _ in range(10):
        _, _, _, _, info = env.step({"car_0": level_index(env, a)})
    t_clip = v / a
    expected = 0.5 * a * t_clip**2 + v * (10 - t_clip)
    assert info["car_0"]["speed"] == pytest.approx(v)
    assert info["car_0"]["position"][0] == pytest.approx(expected, abs=1e-3)
    x_before = info["car_0"]["position"][0]
    for _ in range(8):  # brake to a halt; never reverses
        _, _, _, _, info = env.step({"car_0": level_index(env, -a)})
    stop = v * v / (2 * a)
    assert info["car_0"]["speed"] == 0.0
    assert info["car_0"]["position"][0] == pytest.approx(x_before + stop, abs=1e-3)


def test_exact_substep_integration_with_clipping():
    ds, v = advance_speed(7.9, 1.5, 8.0, 0.1)
    tau = 0.1 / 1.5
    assert v == 8.0
    assert ds == pytest.approx(0.5 * (7.9 + 8.0) * tau + 8.0 * (0.1 - tau))
    ds, v = advance_speed(0.1, -1.5, 8.0, 0.1)
    assert v == 0.0 and ds == pytest.approx(0.1 * 0.1 / 1.5 / 2)


@pytest.mark.parametrize("reverse", [False, True])
def test_euler_integration_moves_at_each_steps_starting_speed(reverse):
    """The paper's code's step (x += v dt, then v += a dt): after n steps of 0.1 s from rest at
    a = 1.5 the car has covered a dt^2 n (n - 1) / 2, short of the exact a (n dt)^2 / 2 by
    a dt^2 n / 2; braking from v_lim it covers as much more; clipped at v_lim and at 0 (or at
    -v_lim where the car may reverse) after the step that crosses it. Positions are Box2D's
    float32 (about 4e-6 m off at 26 m); the two integrations differ by 0.075 m per second."""
    env = hand_env([straight_car((0, 0), (300, 0))], horizon=30, integration="euler", reverse=reverse)
    env.reset(seed=0)
    a, dt, k = 1.5, env.config.dt, env.config.substeps
    for t in range(1, 4):
        _, _, _, _, info = env.step({"car_0": level_index(env, a)})
        n = t * k
        assert info["car_0"]["speed"] == pytest.approx(a * n * dt, abs=1e-9)
        assert info["car_0"]["position"][0] == pytest.approx(a * dt * dt * n * (n - 1) / 2, abs=1e-4)
        assert info["car_0"]["position"][0] == pytest.approx(0.5 * a * (n * dt) ** 2 - a * dt * dt * n / 2, abs=1e-4)
    for _ in range(3):  # 6 s at 1.5 m/s^2 from 4.5 m/s: the speed reaches 8 m/s and stays there
        _, _, _, _, info = env.step({"car_0": level_index(env, a)})
    speeds, x = [4.5], 0.0
    for _ in range(3 * k):
        x += speeds[-1] * dt
        speeds.append(min(speeds[-1] + a * dt, env.config.v_lim))
    assert info["car_0"]["speed"] == pytest.approx(env.config.v_lim)
    x_before = info["car_0"]["position"][0]
    assert x_before == pytest.approx(a * dt * dt * 30 * 29 / 2 + x, abs=1e-4)
    for _ in range(8):  # 8 s of braking from 8 m/s: a halt after 5.33 s, or backing to -v_lim
        _, _, _, _, info = env.step({"car_0": level_index(env, -a)})
    v, x = env.config.v_lim, x_before
    for _ in range(8 * k):
        x += v * dt
        v = min(max(v - a * dt, -env.config.v_lim if reverse else 0.0), env.config.v_lim)
    assert info["car_0"]["speed"] == pytest.approx(v, abs=1e-9)
    assert info["car_0"]["position"][0] == pytest.approx(x, abs=1e-4)
    assert (v < 0) == reverse


def test_an_euler_step_falls_short_of_the_exact_one_by_half_a_dt_squared():
    """Over random speeds, accelerations and steps: the Euler step moves ``v * dt``; where the speed
    reaches no limit inside the step both end at ``v + a * dt`` and the exact step covers
    ``a * dt^2 / 2`` more; where it does, both end at that limit."""
    from box2d_driving.physics.kinematics import advance_speed_between, euler_speed

    rng = np.random.default_rng(0)
    for v, a, dt in zip(rng.uniform(-8, 8, 2000), rng.uniform(-1.5, 1.5, 2000), rng.uniform(0.01, 2.0, 2000)):
        ds_euler, v_euler = euler_speed(v, a, -8.0, 8.0, dt)
        ds_exact, v_exact = advance_speed_between(v, a, -8.0, 8.0, dt)
        assert ds_euler == v * dt and v_euler == v_exact
        if -8.0 <= v + a * dt <= 8.0:
            assert v_euler == pytest.approx(v + a * dt) and ds_exact - ds_euler == pytest.approx(a * dt * dt / 2)
        else:
            assert v_euler == (8.0 if a > 0 else -8.0)


def test_integration_is_a_checked_choice():
    with pytest.raises(box2d_driving.ConfigError, match="integration"):
        box2d_driving.make("intersection-v0", integration="rk4")


def _lidar_distances(env, car=0):
    return env._lidar_distances(np.array([car]))[0]


@pytest.mark.parametrize("backend", BACKENDS)
def test_lidar_ray_hits_wall_at_known_distance(backend):
    wall = [[[20.0, -30.0], [20.0, 30.0]]]
    env = hand_env([straight_car((0, 0), (10, 0))], edges=wall, n_rays=100, lidar_backend=backend)
    env.reset(seed=0)
    d = _lidar_distances(env)
    angles = np.arange(100) * 2 * np.pi / 100
    for k, th in enumerate(angles):
        c = math.cos(th)
        if c > 0 and abs(20 * math.tan(th)) < 30 and 20 / c <= 50:
            assert d[k] == pytest.approx(20 / c, abs=0.01)
        else:
            assert d[k] == np.inf
    obs, _ = env.reset(seed=0)
    lidar, _ = env.observation_layout.split(obs["car_0"])
    assert lidar[-1, 0] == pytest.approx(1 / 20, abs=1e-5)


@pytest.mark.parametrize("backend", BACKENDS)
def test_lidar_sees_a_car_at_known_pose_and_not_itself(backend):
    cars = [
        straight_car((0, 0), (10, 0)),
        straight_car((15, 0), (15, 10)),  # heading +90 degrees: its side faces us
        straight_car((-20, 0), (-30, 0)),  # heading 180 degrees: its rear... front faces away
    ]
    env = hand_env(cars, n_rays=4, lidar_backend=backend)
    env.reset(seed=0)
    d = _lidar_distances(env)
    assert d[0] == pytest.approx(15 - 2.2 / 2, abs=0.01)
    assert d[2] == pytest.approx(20 - 4.48 / 2, abs=0.01)
    assert d[1] == np.inf and d[3] == np.inf  # own body excluded, nothing else there


@pytest.mark.parametrize("noise", [0.0, 0.25, 0.5, 0.75, 0.333])
def test_noise_drops_exactly_round_p_n_rays(noise):
    box = [[[-10, -10], [10, -10]], [[10, -10], [10, 10]], [[10, 10], [-10, 10]], [[-10, 10], [-10, -10]]]
    cars = [straight_car((0, 0), (5, 0)), straight_car((0, -5), (5, -5))]
    env = hand_env(cars, edges=box, n_rays=100, lidar_noise=noise)
    env.reset(seed=1)
    for _ in range(5):
        obs, *_ = env.step({a: level_index(env, 0.0) for a in env.agents})
        for a in obs:
            lidar, _ = env.observation_layout.split(obs[a])
            assert np.count_nonzero(lidar[-1] == 0) == int(math.floor(noise * 100 + 0.5))


def test_dropped_rays_differ_between_decisions_and_cars():
    box = [[[-10, -10], [10, -10]], [[10, -10], [10, 10]], [[10, 10], [-10, 10]], [[-10, 10], [-10, -10]]]
    cars = [straight_car((0, 0), (5, 0)), straight_car((0, -5), (5, -5))]
    env = hand_env(cars, edges=box, n_rays=100, lidar_noise=0.5)
    obs, _ = env.reset(seed=1)
    l0, _ = env.observation_layout.split(obs["car_0"])
    l1, _ = env.observation_layout.split(obs["car_1"])
    obs2, *_ = env.step({a: level_index(env, 0.0) for a in env.agents})
    l0b, _ = env.observation_layout.split(obs2["car_0"])
    assert not np.array_equal(l0[-1] == 0, l1[-1] == 0)
    assert not np.array_equal(l0[-1] == 0, l0b[-1] == 0)


def _first_overlap_step(gap: float, a: float, dt: float, v_lim: float) -> int:
    """Physics step at which two cars accelerating towards each other from rest close ``gap``."""
    s, v, k = 0.0, 0.0, 0
    while 2 * s < gap:
        ds, v = advance_speed(v, a, v_lim, dt)
        s += ds
        k += 1
    return k


def test_head_on_cars_collide_on_the_predicted_decision():
    env = hand_env([straight_car((-30, 0), (100, 0)), straight_car((30, 0), (-100, 0))], horizon=20)
    env.reset(seed=0)
    gap = 60 - env.config.car_length
    k = _first_overlap_step(gap, 1.5, env.config.dt, env.config.v_lim)
    expected_decision = math.ceil(k / env.config.substeps)
    up = level_index(env, 1.5)
    for t in range(1, 20):
        _, rewards, term, _, info = env.step({a: up for a in env.agents})
        if any(term.values()):
            break
    assert t == expected_decision
    assert term == {"car_0": True, "car_1": True}
    assert info["car_0"]["collided_with"] == "car" and info["car_1"]["collided_with"] == "car"
    assert info["car_0"]["collision_partner"] == 1 and info["car_1"]["collision_partner"] == 0
    assert not info["car_0"]["partner_halted"] and not info["car_1"]["partner_halted"]
    assert rewards["car_0"] == pytest.approx(rewards["car_1"])
    assert info["car_0"]["reward_terms"]["collision"] == -1.0
    # halted exactly where they touched: fronts just overlapping
    x0, x1 = info["car_0"]["position"][0], info["car_1"]["position"][0]
    overlap = env.config.car_length - (x1 - x0)
    assert 0 < overlap <= 2 * 0.1 * env.config.v_lim
    assert info["car_0"]["speed"] == 0.0


def test_cars_point_one_metre_apart_do_not_collide():
    w = 2.2
    cars = [straight_car((-40, 0), (60, 0)), straight_car((40, w + 0.1), (-60, w + 0.1)),
            straight_car((-40, -w - 0.1), (60, -w - 0.1))]
    env = hand_env(cars, horizon=15)
    env.reset(seed=0)
    up = level_index(env, 1.5)
    for _ in range(15):
        _, _, term, trunc, info = env.step({a: up for a in env.agents})
        assert not any(term.values())
    assert all(trunc.values())
    assert not any(i["collided"] for i in info.values())


def _max_speed_of_any_scenario() -> float:
    return max(box2d_driving.make(e).config.max_speed() for e in registry())


def test_no_tunnelling_through_a_thin_edge_at_top_speed():
    v = _max_speed_of_any_scenario()
    a = 3.0
    run_up = v * v / (2 * a) + 5
    wall_x = run_up + 7.3  # an arbitrary offset so the crossing falls between physics steps
    env = hand_env([straight_car((0, 0), (wall_x + 50, 0))],
                   edges=[[[wall_x, -20], [wall_x, 20]]], v_lim=v,
                   accelerations=(-a, 0.0, a), horizon=30)
    env.reset(seed=0)
    for _ in range(30):
        _, _, term, _, info = env.step({"car_0": 2})
        if term["car_0"]:
            break
    assert info["car_0"]["collided_with"] == "edge" and info["car_0"]["collision_partner"] == -1
    front = info["car_0"]["position"][0] + env.config.car_length / 2
    assert wall_x <= front < wall_x + v * env.config.dt + 1e-6


def test_no_tunnelling_head_on_at_top_speed():
    v = _max_speed_of_any_scenario()
    a = 3.0
    run_up = v * v / (2 * a) + 1
    cars = [straight_car((-run_up - 5, 0), (200, 0)), straight_car((run_up + 5, 0), (-200, 0))]
    env = hand_env(cars, v_lim=v, accelerations=(-a, 0.0, a), horizon=30)
    env.reset(seed=0)
    for _ in range(30):
        _, _, term, _, info = env.step({x: 2 for x in env.agents})
        if any(term.values()):
            break
    assert info["car_0"]["collided_with"] == "car"
    assert info["car_0"]["position"][0] < info["car_1"]["position"][0]


def test_tunnelling_speeds_are_rejected():
    with pytest.raises(box2d_driving.ConfigError, match="tunnel|physics step"):
        box2d_driving.make("intersection-v0", v_lim=25.0)


@pytest.mark.parametrize("backend", BACKENDS)
def test_pedestrian_is_seen_and_hitting_it_ends_the_car(backend):
    ped = PedestrianSpawn(np.array([20.0, 0.0]), np.zeros(2), (-50.0, 50.0), 0.8)
    env = hand_env([straight_car((0, 0), (100, 0)), straight_car((0, -10), (100, -10))],
                   layout_kw={"pedestrians": [ped]}, lidar_backend=backend, horizon=30)
    env.reset(seed=0)
    assert _lidar_distances(env)[0] == pytest.approx(20 - 0.4, abs=0.01)
    up = level_index(env, 1.5)
    for _ in range(30):
        _, rewards, term, _, info = env.step({a: up for a in env.agents})
        if term.get("car_0"):
            break
    assert info["car_0"]["collided_with"] == "pedestrian"
    assert info["car_0"]["reward_terms"]["collision"] == -1.0
    assert "car_0" not in env.agents and "car_1" in env.agents


def test_collided_car_stays_as_an_obstacle():
    # car_0 and car_1 collide head-on; car_2 drives into the wreck later
    cars = [straight_car((-10, 0), (100, 0)), straight_car((10, 0), (-100, 0)),
            straight_car((-60, 0), (100, 0))]
    env = hand_env(cars, horizon=30)
    env.reset(seed=0)
    up, zero = level_index(env, 1.5), level_index(env, 0.0)
    for _ in range(30):
        acts = {a: up if a != "car_2" or env.decision > 3 else zero for a in env.agents}
        _, _, term, _, info = env.step(acts)
        if term.get("car_2"):
            break
    assert info["car_2"]["collided_with"] == "car"
    assert info["car_2"]["collision_partner"] == 0 and info["car_2"]["partner_halted"]  # the wreck
    assert env.world.positions[0][0] == pytest.approx(info["car_2"]["position"][0] + 4.48, abs=1.7)


def test_collided_car_is_removed_when_configured():
    cars = [straight_car((-10, 0), (100, 0)), straight_car((10, 0), (-100, 0)),
            straight_car((-60, 0), (100, 0))]
    env = hand_env(cars, horizon=30, remove_collided=True)
    env.reset(seed=0)
    up = level_index(env, 1.5)
    zero = level_index(env, 0.0)
    for _ in range(30):
        if not env.agents:
            break
        acts = {a: up if a != "car_2" or env.decision > 3 else zero for a in env.agents}
        _, _, term, trunc, info = env.step(acts)
        if "car_2" in info and (term["car_2"] or trunc["car_2"]):
            break
    assert info["car_2"]["arrived"]


def test_arrived_car_leaves_the_world():
    env = hand_env([straight_car((0, 0), (5, 0)), straight_car((-20, 0), (40, 0))], horizon=20)
    env.reset(seed=0)
    up = level_index(env, 1.5)
    _, _, term, _, info = env.step({a: up for a in env.agents})
    for _ in range(3):
        _, _, term, _, info = env.step({a: up for a in env.agents})
        if term.get("car_0"):
            break
    assert info["car_0"]["arrived"] and not info["car_0"]["collided"]
    assert info["car_0"]["distance_to_goal"] == 0.0
    assert not env.world.present[0]
    for _ in range(15):  # car_1 drives through the goal spot of car_0 unharmed
        if not env.agents:
            break
        _, _, term, _, info = env.step({a: up for a in env.agents})
    assert info["car_1"]["arrived"]


@pytest.mark.parametrize("env_id", sorted(registry()))
def test_lidar_backends_agree_on_every_ray(env_id):
    rng = np.random.default_rng(0)
    overrides = {"num_cars": 8} if env_id != "crosswalk-v0" else {}
    fast = box2d_driving.make(env_id, lidar_backend="numba", **overrides)
    slow = box2d_driving.make(env_id, lidar_backend="box2d", **overrides)
    for seed in range(3):
        fast.reset(seed=seed)
        slow.reset(seed=seed)
        for _ in range(12):
            if not fast.agents:
                break
            cars = np.array([fast._index[a] for a in fast.agents])
            a = fast._lidar_distances(cars)
            b = slow._lidar_distances(cars)
            assert np.array_equal(np.isinf(a), np.isinf(b))
            finite = np.isfinite(a)
            assert np.max(np.abs(a[finite] - b[finite]), initial=0.0) < 1e-3
            acts = {x: int(rng.integers(fast.action_space(x).n)) for x in fast.agents}
            fast.step(acts)
            slow.step(acts)


def test_car_following_a_spline_stays_on_it():
    path = spline_path(np.array([[0, 0], [20, 5], [40, -5], [60, 10], [80, 0]]))
    from box2d_driving.road.layout import CarSpawn
    env = hand_env([CarSpawn(path=path)], horizon=20)
    env.reset(seed=0)
    up = level_index(env, 1.0)
    for _ in range(20):
        _, _, term, _, info = env.step({"car_0": up})
        pos = info["car_0"]["position"]
        s = path.project(pos)
        p, heading = path.pose(s)
        assert np.linalg.norm(p - pos) < 0.01
        assert abs((info["car_0"]["heading"] - heading + np.pi) % (2 * np.pi) - np.pi) < 0.02
        if term["car_0"]:
            break
    assert info["car_0"]["arrived"]


@pytest.mark.parametrize("env_id", ["intersection-v0", "intersection-spline-v0", "real-junction-v0", "crosswalk-v0"])
def test_cached_poses_and_velocity_records_match_the_bodies_after_every_decision(env_id):
    """The world reads back only the poses of cars that moved and skips velocity writes its
    records say are already in place: after every decision both must agree with Box2D itself."""
    rng = np.random.default_rng(1)
    env = box2d_driving.make(env_id, **({"num_cars": 8} if env_id != "crosswalk-v0" else {}))
    for seed in range(4):
        env.reset(seed=seed)
        while env.agents:
            env.step({x: int(rng.integers(env.action_space(x).n)) for x in env.agents})
            w = env.world
            bodies = w.car_bodies
            assert np.array_equal(w.positions, np.array([b.position.tuple for b in bodies]))
            assert np.array_equal(w.headings, wrap_angle(np.array([b.angle for b in bodies])))
            for i in np.flatnonzero(w.status == 0):  # cars still driving
                v = bodies[i].linearVelocity
                assert w._standing[i] == (v.x == 0.0 and v.y == 0.0)
                assert np.float32(w._angular[i]) == np.float32(bodies[i].angularVelocity)
