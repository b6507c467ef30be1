"""Spline scenarios: stage-0 action decoding, paths through the chosen points, the two-phase
reset, the spline_policy hook, bad input, spawns that never overlap."""

import itertools

import numpy as np
import pytest

import box2d_driving
from box2d_driving.road.geometry import rectangle_corners, rectangles_overlap


def test_junction_action_decoding_covers_216_distinct_offset_triples():
    env = box2d_driving.make("intersection-spline-v0", num_cars=4, spline_action="joint")
    assert env.spline_action_space.n == 216
    offsets = env.decode_offsets(np.arange(216))
    sizes = {0.0, 1 / 3, 2 / 3}
    assert set(np.round(np.abs(offsets), 9).ravel()) == {round(s, 9) for s in sizes}
    # each waypoint takes right/left versions of every size; 0 appears once per side
    for j in range(3):
        assert np.sum(offsets[:, j] > 0) == 216 * 2 // 6 and np.sum(offsets[:, j] < 0) == 216 * 2 // 6
    choices = np.array(list(itertools.product(range(6), repeat=3)))
    assert np.array_equal(np.sort(env.encode_offsets(choices)), np.arange(216))
    assert np.array_equal(env.decode_offsets(np.zeros(1, dtype=int)), np.zeros((1, 3)))


def test_junction_path_passes_through_the_offset_waypoints():
    env = box2d_driving.make("intersection-spline-v0", num_cars=4)
    assert env.spline_action_space.nvec.tolist() == [6, 6, 6]  # per-waypoint choices (default)
    planned = env.plan(seed=5)
    base = env._planned
    choices = np.array([[1, 4, 2], [0, 0, 0], [5, 3, 1], [2, 2, 2]])  # digits per waypoint
    env.reset(options={"use_plan": True, "spline_actions": choices})
    sizes = np.array([0.0, 1 / 3, 2 / 3])
    for i, car in enumerate(env.layout.cars):
        axis = base.cars[i].lane_axis
        right = np.array([axis.direction[1], -axis.direction[0]])  # computed here, not by LaneAxis
        signed = np.where(choices[i] < 3, sizes[choices[i] % 3], -sizes[choices[i] % 3]) * axis.half_width
        expected = [base.cars[i].path.points[0] + signed[0] * right, signed[1] * right,
                    base.cars[i].path.points[-1] + signed[2] * right]
        pts = car.path.points
        for p in expected:
            assert np.min(np.linalg.norm(pts - p, axis=1)) < 1e-9  # a control point is a vertex
        assert np.allclose(pts[0], expected[0]) and np.allclose(pts[-1], expected[2])
        # lane position of the spawn, as reported, is the chosen first offset
        assert axis.offset(pts[0]) == pytest.approx(signed[0] / axis.half_width)
    assert set(planned) == set(env.possible_agents)
    # the joint encoding of the same choices builds the same paths
    joint = box2d_driving.make("intersection-spline-v0", num_cars=4, spline_action="joint")
    joint.reset(seed=5, options={"spline_actions": env.encode_offsets(choices)})
    for a, b in zip(env.layout.cars, joint.layout.cars):
        assert np.array_equal(a.path.points, b.path.points)


@pytest.mark.parametrize("env_id", ["intersection-spline-v0", "highway-spline-v0"])
def test_two_phase_reset_equals_one_reset_with_the_same_actions(env_id):
    a = box2d_driving.make(env_id)
    b = box2d_driving.make(env_id)
    rng = np.random.default_rng(0)
    space = a.spline_action_space
    if hasattr(space, "nvec"):
        actions = rng.integers(0, space.nvec, size=(len(a.possible_agents), len(space.nvec)))
    else:
        actions = rng.uniform(-1, 1, size=(len(a.possible_agents), 1)).astype(np.float32)
    obs0 = a.plan(seed=11)
    obs_a, _ = a.reset(options={"use_plan": True, "spline_actions": actions})
    obs_b, _ = b.reset(seed=11, options={"spline_actions": actions})
    for agent in a.possible_agents:
        assert np.array_equal(obs_a[agent], obs_b[agent])
        assert obs0[agent] in a.spline_observation_space
    for _ in range(5):
        acts = {ag: 7 for ag in a.agents}
        oa, ra, *_ = a.step(acts)
        ob, rb, *_ = b.step(acts)
        assert all(np.array_equal(oa[k], ob[k]) and ra[k] == rb[k] for k in oa)


def test_spline_policy_hook_sees_stage0_observations_and_chooses():
    env = box2d_driving.make("intersection-spline-v0", num_cars=4, spline_action="joint")
    seen = []

    def policy(obs0):
        seen.append(obs0.copy())
        return np.full(len(obs0), 215)

    env.spline_policy = policy
    env.reset(seed=3)
    assert seen and seen[0].shape == (4, 7)
    assert np.array_equal(env.spline_actions, np.full(4, 215))
    assert np.allclose(env.decode_offsets(env.spline_actions), -2 / 3)
    # explicit actions win over the hook
    env.reset(seed=3, options={"spline_actions": np.zeros(4, dtype=int)})
    assert np.array_equal(env.spline_actions, np.zeros(4))


def test_spline_reset_rejects_bad_input():
    env = box2d_driving.make("intersection-spline-v0", num_cars=4, spline_action="joint")
    with pytest.raises(RuntimeError, match="plan"):
        env.reset(options={"use_plan": True})
    env.plan(seed=0)
    with pytest.raises(ValueError, match="plan\\(seed\\)"):
        env.reset(seed=1, options={"use_plan": True})
    with pytest.raises(ValueError, match="216"):
        env.reset(seed=1, options={"spline_actions": [0, 1, 2, 216]})
    with pytest.raises(ValueError, match="car_3"):
        env.reset(seed=1, options={"spline_actions": {"car_0": 0, "car_1": 0, "car_2": 0}})
    per = box2d_driving.make("intersection-spline-v0", num_cars=2)
    with pytest.raises(ValueError, match="shape"):
        per.reset(seed=0, options={"spline_actions": [1, 2]})
    with pytest.raises(ValueError, match="6, 6, 6"):
        per.reset(seed=0, options={"spline_actions": [[0, 0, 6], [0, 0, 0]]})
    with pytest.raises(box2d_driving.ConfigError, match="spline_action"):
        box2d_driving.make("intersection-spline-v0", spline_action="both")
    hw = box2d_driving.make("highway-spline-v0", num_cars=2)
    with pytest.raises(ValueError, match="finite"):
        hw.reset(seed=0, options={"spline_actions": [[np.nan], [0.0]]})
    with pytest.raises(box2d_driving.ConfigError, match="spline_offsets"):
        box2d_driving.make("intersection-spline-v0", spline_offsets=(0.0, 0.9))


@pytest.mark.parametrize("env_id,n", [("intersection-spline-v0", 16), ("highway-spline-v0", 12)])
def test_spline_spawns_never_overlap(env_id, n):
    env = box2d_driving.make(env_id, num_cars=n)
    rng = np.random.default_rng(1)
    cfg = env.config
    for seed in range(150):
        space = env.spline_action_space
        acts = (rng.integers(0, space.nvec, (n, 3)) if hasattr(space, "nvec")
                else rng.uniform(-1, 1, (n, 1)))
        env.reset(seed=seed, options={"spline_actions": acts})
        w = env.world
        boxes = [rectangle_corners(*w.positions[i], w.headings[i], cfg.car_length, cfg.car_width)
                 for i in range(n)]
        for i, j in itertools.combinations(range(n), 2):
            assert not rectangles_overlap(boxes[i], boxes[j]), (seed, i, j)


def test_highway_lateral_target_and_rating_observation():
    env = box2d_driving.make("highway-spline-v0", num_cars=3)
    obs0 = env.plan(seed=4)
    ratings = [c.rating for c in env._planned.cars]
    assert [float(obs0[a][0]) for a in env.possible_agents] == pytest.approx(ratings)
    env.reset(options={"use_plan": True, "spline_actions": [[1.0], [-1.0], [0.5]]})
    cfg = env.config
    limit = cfg.spline_lateral_limit * cfg.road_width / 2
    for car, target in zip(env.layout.cars, [limit, -limit, 0.5 * limit]):
        start, end = car.path.points[0], car.path.points[-1]
        assert start[1] == 0.0 and end[1] == pytest.approx(target)
        pos, _ = car.path.pose(car.path.project(np.array([start[0] + cfg.lane_change_distance, target])))
        assert pos[1] == pytest.approx(target, abs=1e-6)


def test_cars_stay_on_their_spline():
    env = box2d_driving.make("intersection-spline-v0", num_cars=4, light_period_range=(100.0, 101.0),
                             spline_action="joint")
    env.reset(seed=2, options={"spline_actions": [215, 43, 100, 7]})
    paths = [c.path for c in env.layout.cars]
    checked = 0
    while env.agents:
        env.step({a: 12 for a in env.agents})
        for i in np.flatnonzero(env.world.status == 0):
            p = paths[i]
            pos, _ = p.pose(p.project(env.world.positions[i]))
            assert np.linalg.norm(pos - env.world.positions[i]) < 0.01
            checked += 1
    assert checked >= 10
