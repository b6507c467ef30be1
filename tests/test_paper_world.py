"""The ``paper`` preset: the world of the paper's own code (sdriving 0.1.0), option by option,
against hand-worked answers. Each option is an ordinary config field, so each is also checked on
its own; the defaults stay as they were (``tests/test_env_golden.py``)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import box2d_driving
from box2d_driving import ConfigError
from box2d_driving.envs.core import arrived_heading_reading
from box2d_driving.presets import PAPER, preset_overrides
from box2d_driving.road.lights import sample_lights
from box2d_driving.sensors import readout

GO = 12  # the largest of the 13 accelerations, +1.5 m/s^2
BRAKE = 0  # -1.5 m/s^2


def _paper(**overrides):
    return box2d_driving.make("intersection-v0", preset="paper", **overrides)


def test_the_preset_sets_its_values_and_overrides_win():
    env = _paper(lidar_noise=0.25, horizon=30)
    cfg = env.config
    for name, value in PAPER.env_overrides["intersection-v0"].items():
        if name != "horizon":
            assert getattr(cfg, name) == pytest.approx(value), name
    assert cfg.horizon == 30 and cfg.lidar_noise == 0.25
    assert preset_overrides("paper", "intersection-v0")["horizon"] == 25
    with pytest.raises(ConfigError, match="unknown preset 'nope'"):
        box2d_driving.make("intersection-v0", preset="nope")
    with pytest.raises(ConfigError, match="no settings for 'highway-v0'"):
        box2d_driving.make("highway-v0", preset="paper")


def test_an_arrived_car_stays_stops_paying_progress_and_pays_for_speed():
    env = box2d_driving.make("intersection-v0", num_cars=1, arrived_cars_stay=True, road_end_walls=True,
                             horizon=40)
    env.reset(seed=0)
    arrival, rows = None, []
    while env.agents:
        obs, rew, term, trunc, info = env.step({"car_0": GO})
        rows.append((rew["car_0"], term["car_0"], info["car_0"]))
        if info["car_0"]["arrived"] and arrival is None:
            arrival = len(rows) - 1
    assert arrival is not None
    r, term, info = rows[arrival]
    assert info["reward_terms"]["goal"] == 1.0 and not term  # arrival does not end the car
    after = rows[arrival + 1]
    v = after[2]["speed"]
    assert after[2]["reward_terms"]["goal"] == 0.0
    assert after[2]["reward_terms"]["progress"] == pytest.approx(-(abs(v) / 8.0) / 40)
    assert after[2]["distance_to_goal"] < 0 and after[2]["arrived"]
    # full throttle on past the goal: it ends against the wall at the end of its arm
    last = rows[-1]
    assert last[1] and last[2]["collided"] and last[2]["collided_with"] == "edge"
    assert last[2]["reward_terms"]["collision"] == -1.0
    assert last[2]["reward_terms"]["progress"] == pytest.approx(-(abs(rows[-2][2]["speed"]) / 8.0) / 40, abs=0.04)


def test_without_staying_an_arrived_car_still_leaves():
    env = box2d_driving.make("intersection-v0", num_cars=1, horizon=40)
    env.reset(seed=0)
    while env.agents:
        _, _, term, _, info = env.step({"car_0": GO})
    assert term["car_0"] and info["car_0"]["arrived"]


def test_reversing_backs_a_car_up_its_track():
    env = box2d_driving.make("intersection-v0", num_cars=1, reverse=True)
    obs, info = env.reset(seed=1)
    x0 = np.array(info["car_0"]["position"])
    obs, _, _, _, info = env.step({"car_0": BRAKE})
    # 1 s at -1.5 m/s^2 from a standstill: -1.5 m/s, 0.75 m backwards
    assert info["car_0"]["speed"] == pytest.approx(-1.5)
    heading = info["car_0"]["heading"]
    back = np.array(info["car_0"]["position"]) - x0
    # Box2D keeps float32 poses
    assert back @ np.array([math.cos(heading), math.sin(heading)]) == pytest.approx(-0.75, abs=1e-4)
    space = env.observation_space("car_0")
    assert space.contains(obs["car_0"])
    speed_field = env.observation_layout.satnav.start + 4 * env.observation_layout.n_satnav + 1
    assert obs["car_0"][speed_field] == pytest.approx(-1.5 / 8.0)
    # without reverse the same braking holds the car still
    still = box2d_driving.make("intersection-v0", num_cars=1)
    still.reset(seed=1)
    _, _, _, _, info = still.step({"car_0": BRAKE})
    assert info["car_0"]["speed"] == 0.0


def test_arrival_within_a_third_of_the_width_of_the_axis_goal():
    env = _paper(num_cars=4, lidar_noise=0.0)
    for seed in range(3):
        env.reset(seed=seed)
        width = 2 * env.layout.junction_box[2]
        goals = env._goals.copy()
        assert np.allclose(np.abs(goals).min(axis=1), 0.0)  # on the road axis
        before = {a: None for a in env.agents}
        while env.agents:
            pos_before = env.world.positions.copy()
            _, _, _, _, info = env.step({a: GO for a in env.agents})
            for a, i in info.items():
                k = int(a.split("_")[1])
                if i["arrived"] and before[a] is None:
                    before[a] = env.decision
                    # inside the radius now, outside it a decision earlier
                    assert np.linalg.norm(np.array(i["position"]) - goals[k]) <= width / 3 + 1e-9
                    assert np.linalg.norm(pos_before[k] - goals[k]) > width / 3


def test_arm_spawns_rotating_approaches_and_no_overlap():
    for seed in range(20):
        env = _paper(num_cars=4)
        _, info = env.reset(seed=seed)
        half = env.layout.junction_box[2]
        length = env.layout.edges[0]  # first arm edge: from the junction to the arm's far end
        arm = np.linalg.norm(np.asarray(length[1]) - np.asarray(length[0]))
        approaches = sorted(i["approach"] for i in info.values())
        assert approaches == [0, 1, 2, 3]  # rotate: one car per approach with four cars
        for i in info.values():
            before = i["stop_line_distance"]  # from the lane's stop point: the junction's edge
            assert 0.2 * arm - 1e-9 <= before <= 0.8 * arm + 1e-9
            # offset / (W/2) = 2 * offset / W, negative: the paper's cars keep to the left
            assert 0.15 - 1e-9 <= -i["lane_offset"] / 2 <= 0.30 + 1e-9
        del half
    crowded = _paper(num_cars=12, approach_order="random")
    for seed in range(10):
        crowded.reset(seed=seed)
        w = crowded.world
        n = len(w.positions)
        for a in range(n):
            for b in range(a + 1, n):
                same_arm = crowded._approach[a] == crowded._approach[b]
                gap = np.abs(w.positions[a] - w.positions[b])
                assert not same_arm or gap.max() >= 2.2 - 1e-9


def test_lights_start_at_green_or_red_on_a_grid_of_steps():
    rng = np.random.default_rng(0)
    offsets = set()
    for _ in range(50):
        lights = sample_lights(rng, np.zeros((4, 2)), np.ones((4, 2)), np.arange(4) % 2, (10.0, 15.0), 1.0,
                               "green_or_red", 0.1)
        assert lights.offset in (0.0, lights.half_period)
        assert round(lights.half_period * 10) == pytest.approx(lights.half_period * 10)
        assert 10.0 <= lights.half_period < 15.0
        offsets.add(lights.offset == 0.0)
        values = lights.values(0.0)
        assert sorted(values.tolist()) == [0.0, 0.0, 1.0, 1.0]  # one group green, the other red
    assert offsets == {True, False}


def test_independent_dropout_drops_each_ray_with_probability_p():
    rng = np.random.default_rng(0)
    draws = readout.dropout_draws(rng, 2000, 100, 0.25, "independent")
    mask = readout.dropout_from_draws(draws, 2000, 100, 0.25, "independent")
    per_car = mask.sum(axis=1)
    assert per_car.mean() == pytest.approx(25.0, abs=0.3)
    assert per_car.std() == pytest.approx(math.sqrt(100 * 0.25 * 0.75), rel=0.1)  # binomial, not fixed
    assert readout.dropout_draws(rng, 3, 100, 0.0, "independent").shape == (0, 100)
    assert not readout.dropout_from_draws(np.zeros((0, 100)), 3, 100, 0.0, "independent").any()
    full = readout.dropout_from_draws(readout.dropout_draws(rng, 3, 100, 1.0, "independent"), 3, 100, 1.0,
                                      "independent")
    assert full.all()


def test_min_range_sees_through_what_is_nearer_than_it():
    near = box2d_driving.make("intersection-v0", num_cars=4, lidar_min_range=20.0)
    far = box2d_driving.make("intersection-v0", num_cars=4)
    lay = near.observation_layout
    seen_through = 0
    for seed in range(4):
        o1, _ = near.reset(seed=seed)
        o2, _ = far.reset(seed=seed)
        for a in o1:
            inv_near, inv_far = o1[a][lay.lidar], o2[a][lay.lidar]
            d_near = np.where(inv_near > 0, 1.0 / np.maximum(inv_near, 1e-12), np.inf)
            d_far = np.where(inv_far > 0, 1.0 / np.maximum(inv_far, 1e-12), np.inf)
            assert (d_near >= 20.0 - 1e-3).all()  # nothing nearer is seen
            keep = d_far > 20.0 + 1e-3
            assert np.array_equal(inv_near[keep], inv_far[keep])  # beyond it, the same returns
            seen_through += int(np.isfinite(d_near[~keep]).sum())  # a farther object behind a near one
    assert seen_through > 0
    with pytest.raises(ConfigError, match="lidar_min_range"):
        box2d_driving.make("intersection-v0", lidar_min_range=60.0)


def test_min_range_in_the_compiled_path_agrees_with_box2d_raycast():
    def rays(backend):
        env = _paper(num_cars=8, approach_order="random", lidar_backend=backend)
        obs, _ = env.reset(seed=5)
        out = [np.stack([obs[a] for a in sorted(obs)])]
        for _ in range(6):
            obs, *_ = env.step({a: GO for a in env.agents})
            out.append(np.stack([obs[a] for a in sorted(obs)]))
        return out
    for x, y in zip(rays("numba"), rays("box2d")):
        dx = np.where(x > 0, 1.0 / np.maximum(x, 1e-12), 0.0)
        dy = np.where(y > 0, 1.0 / np.maximum(y, 1e-12), 0.0)
        assert ((x > 0) == (y > 0)).mean() > 0.999
        both = (x > 0) & (y > 0)
        assert np.abs(dx[both] - dy[both]).max() < 1e-3


def test_squared_smoothness_on_a_worked_case():
    env = box2d_driving.make("intersection-v0", num_cars=1, smoothness="squared", horizon=25)
    env.reset(seed=0)
    env.step({"car_0": 6})  # 0.0 m/s^2
    _, _, _, _, info = env.step({"car_0": 12})  # 0 -> 1.5: a change of half the range
    assert info["car_0"]["reward_terms"]["smoothness"] == pytest.approx(-(1.5 / 3.0) ** 2 / 25)


def test_driving_on_the_left_is_the_mirror_image_of_the_right():
    right, left = _paper(drive_on="right"), _paper()
    for seed in range(5):
        _, a = right.reset(seed=seed)
        _, b = left.reset(seed=seed)
        for car in a:  # the same draws, each car on the other side of its road
            assert b[car]["lane_offset"] == pytest.approx(-a[car]["lane_offset"])
            assert b[car]["stop_line_distance"] == pytest.approx(a[car]["stop_line_distance"])
            assert b[car]["approach"] == a[car]["approach"]
        # the stop lines cover the half of the road the cars come in on
        lines = left.layout.stop_lines
        for car in left.layout.cars:
            start, end = lines[car.approach]
            assert np.dot(np.asarray(car.path.points[0]) - start, end - start) > 0  # the track's side of the axis
    with pytest.raises(ConfigError, match="drive_on"):
        box2d_driving.make("intersection-spline-v0", drive_on="left")


def test_an_arrived_cars_heading_error_is_minus_its_heading_as_the_paper_reads_it():
    env = _paper(num_cars=1, horizon=40)
    zero = _paper(num_cars=1, horizon=40, arrived_heading_error="zero")
    layout = env.observation_layout
    # the paper's code, by direction of travel (its headings in (-pi, pi], due west +pi as a
    # float32): east 0 -> 0, north pi/2 -> -pi/2, west +pi -> -pi, south -pi/2 -> +pi/2
    paper_reads = {0: 0.0, 1: -math.pi / 2, 2: -math.pi, 3: math.pi / 2}
    seen_directions = set()
    for seed in range(24):
        seen = {}
        for name, e in (("minus", env), ("zero", zero)):
            obs, _ = e.reset(seed=seed)
            while e.agents:
                obs, _, _, _, info = e.step({"car_0": GO if not seen.get(name) else BRAKE})
                if "car_0" in info and info["car_0"]["arrived"]:
                    heading = e.world.headings[0]
                    seen[name] = float(obs["car_0"][layout.satnav].reshape(layout.history, -1)[-1, 2])
                    break
        direction = round(heading / (math.pi / 2)) % 4
        seen_directions.add(direction)
        assert seen["minus"] == pytest.approx(paper_reads[direction], abs=1e-6) and seen["zero"] == 0.0
    assert seen_directions == {0, 1, 2, 3}
    # at the cut: a heading just either side of +-pi is due west, read as -pi
    for heading in (math.pi, -math.pi, np.nextafter(-math.pi, 0.0), -3.14159257, 3.1415927):
        assert arrived_heading_reading(np.array([heading]))[0] == pytest.approx(-math.pi, abs=1e-6)
    assert arrived_heading_reading(np.array([3.0]))[0] == pytest.approx(-3.0)  # away from it, minus the heading


def test_an_arrived_car_that_backs_out_past_its_goal_still_reads_as_arrived_as_the_paper_reads_it():
    """The paper's code moves an arrived car's goal onto it for good; our own readings (heading
    error 0, the track's distance) follow the track again once the car is behind its goal."""
    paper = _paper(num_cars=1, horizon=60)
    ours = _paper(num_cars=1, horizon=60, arrived_heading_error="zero", goal_distance="path")
    layout = paper.observation_layout
    for env, backed_out_reads_arrived in ((paper, True), (ours, False)):
        obs, _ = env.reset(seed=3)
        arrived, behind = False, None
        while env.agents and behind is None:
            obs, _, _, _, info = env.step({"car_0": BRAKE if arrived else GO})
            arrived = arrived or bool(info["car_0"]["arrived"])
            if arrived and env.world.s[0] < env.world.s_goal[0]:  # reversed back behind its goal
                behind = obs["car_0"][layout.satnav].reshape(layout.history, -1)[-1]
        assert behind is not None and env.world.speed[0] < 0
        heading = env.world.headings[0]
        if backed_out_reads_arrived:
            assert behind[3] == 1.0
            assert behind[2] == pytest.approx(float(arrived_heading_reading(np.array([heading]))[0]), abs=1e-6)
        else:
            assert behind[3] < 1.0 and abs(behind[2]) < 0.5  # towards its goal again, along the track


def test_the_goal_distance_is_read_in_a_straight_line_to_the_axis_goal_as_the_paper_reads_it():
    env, path = _paper(num_cars=1, horizon=40), _paper(num_cars=1, horizon=40, goal_distance="path")
    layout = env.observation_layout

    def inv(obs):  # the newest frame's 1 / max(distance, 1)
        return float(obs["car_0"][layout.satnav].reshape(layout.history, -1)[-1, 3])

    for seed in range(3):
        obs, _ = env.reset(seed=seed)
        along, _ = path.reset(seed=seed)
        goal = np.asarray(env.layout.cars[0].goal)  # on the road axis
        arrived = False
        while env.agents and not arrived:
            assert inv(obs) == pytest.approx(1.0 / max(np.linalg.norm(goal - env.world.positions[0]), 1.0), rel=1e-6)
            # the track's reading: the length left to the arrival point, r * W short of the goal
            assert inv(along) == pytest.approx(1.0 / max(path.world.s_goal[0] - path.world.s[0], 1.0), rel=1e-6)
            obs, _, _, _, info = env.step({"car_0": GO})
            along, *_ = path.step({"car_0": GO})
            arrived = bool(info["car_0"]["arrived"])
        assert arrived and inv(obs) == 1.0 and inv(along) == 1.0  # past the goal: 1 either way


def test_a_car_sees_its_light_within_30_m_of_its_arms_axis_at_the_junction_as_the_paper_reads_it():
    """``light_view="axis_point"``: the light is in view while the car's centre is less than 30 m
    in a straight line from where its arm's axis meets the junction, until it passes that line;
    a car off the axis sees it later than along the approach to its stop line."""
    axis, line = _paper(num_cars=4, horizon=25), _paper(num_cars=4, horizon=25, light_view="stop_line")
    layout = axis.observation_layout
    later = 0
    for seed in range(6):
        seen = {}
        for name, env in (("axis", axis), ("line", line)):
            obs, _ = env.reset(seed=seed)
            half = env.layout.junction_box[2]
            rows = []
            while env.agents:
                for agent in env.agents:
                    i = int(agent.split("_")[1])
                    car = env.layout.cars[i]
                    d = car.lane_axis.direction
                    pos = env.world.positions[i]
                    axis_point = -half * d  # the arm's axis at the junction's edge
                    ahead = float(np.dot(axis_point - pos, d))
                    reads = float(obs[agent][layout.satnav].reshape(layout.history, -1)[-1, 0])
                    rows.append((i, env.decision, reads != 0.75, ahead, float(np.linalg.norm(axis_point - pos))))
                obs, *_ = env.step({a: GO for a in env.agents})
            seen[name] = rows
        for i, decision, in_view, ahead, straight in seen["axis"]:
            assert in_view == (ahead > 0 and straight < 30.0), (seed, i, decision)
        line_view = {(i, dec): v for i, dec, v, _, _ in seen["line"]}
        later += sum(line_view.get((i, dec), False) and not v for i, dec, v, _, _ in seen["axis"])
    assert later > 0  # off the axis, some decisions see the light along the approach but not yet from the axis
    with pytest.raises(ConfigError, match="light_view"):
        box2d_driving.make("intersection-spline-v0", light_view="axis_point")


@pytest.mark.parametrize("overrides, field", [
    ({"spawn_mode": "everywhere"}, "spawn_mode"), ({"approach_order": "left"}, "approach_order"),
    ({"arm_spawn_range": (0.9, 0.1)}, "arm_spawn_range"), ({"lane_offset_range": (0.3, 0.6)}, "lane_offset_range"),
    ({"goal_radius": 0.1, "lane_offset_range": (0.15, 0.3)}, "goal_radius"), ({"light_start": "red"}, "light_start"),
    ({"lidar_dropout": "some"}, "lidar_dropout"), ({"smoothness": "cubic"}, "smoothness"),
    ({"light_period_step": -0.1}, "light_period_step"), ({"drive_on": "middle"}, "drive_on"),
    ({"arrived_heading_error": "pi"}, "arrived_heading_error"), ({"goal_distance": "sideways"}, "goal_distance"),
    ({"light_view": "everywhere"}, "light_view"),
])
def test_bad_values_name_their_field(overrides, field):
    with pytest.raises(ConfigError, match=field):
        box2d_driving.make("intersection-v0", **overrides)


def test_a_crowded_arm_is_one_clear_error():
    with pytest.raises(ConfigError, match="no free spawn"):
        env = _paper(num_cars=16, approach_order="random", arm_spawn_range=(0.2, 0.21))
        for seed in range(5):
            env.reset(seed=seed)
