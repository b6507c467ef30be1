"""Turning tracks at the four-way junction (``turns=True``): geometry against the circle they
approximate, the exit draw, goals on the road turned into, and lone cars that arrive."""

import math

import numpy as np
import pytest

import box2d_driving
from box2d_driving.envs.intersection import IntersectionConfig
from box2d_driving.road.turns import TURN_SEGMENTS, exit_direction, turning_track

DIRS = [np.array([math.cos(a * math.pi / 2), math.sin(a * math.pi / 2)]) for a in range(4)]


def _right(v):
    return np.array([v[1], -v[0]])


def test_exit_direction_left_is_counter_clockwise_right_is_clockwise():
    east = np.array([1.0, 0.0])
    assert np.allclose(exit_direction(east, 0), east)
    assert np.allclose(exit_direction(east, 1), [0.0, 1.0])
    assert np.allclose(exit_direction(east, -1), [0.0, -1.0])
    with pytest.raises(ValueError, match="turn must be"):
        exit_direction(east, 2)


@pytest.mark.parametrize("drive_on", ["right", "left"])
@pytest.mark.parametrize("approach", range(4))
@pytest.mark.parametrize("turn", [1, -1])
def test_a_turn_is_a_quarter_circle_about_a_junction_corner_that_keeps_the_cars_side(drive_on, approach, turn):
    half, lane, before, after = 9.0, 3.1, 20.0, 30.0
    d = DIRS[approach]
    side = _right(d) if drive_on == "right" else -_right(d)
    out = exit_direction(d, turn)
    path, leave_s = turning_track(d, side, lane, half, before, out, after)
    pts = path.points
    entry, leave = pts[1], pts[-2]
    assert np.allclose(pts[0], entry - before * d)
    assert np.allclose(entry, -half * d + lane * side)
    corner = -half * d + half * out
    radius = half - lane if side @ out > 0 else half + lane  # towards its own side: the tight turn
    assert np.allclose(np.linalg.norm(pts[1:-1] - corner, axis=1), radius)
    # it leaves on the exit road's edge, lane metres from its axis on the side the car keeps to
    out_side = _right(out) if drive_on == "right" else -_right(out)
    assert leave @ out == pytest.approx(half)
    assert leave @ out_side == pytest.approx(lane)
    assert np.allclose(pts[-1], leave + after * out)
    # tangent on entry and on leaving: no kink at either join
    assert np.allclose((pts[2] - pts[1]) / np.linalg.norm(pts[2] - pts[1]), d, atol=math.pi / TURN_SEGMENTS)
    assert np.allclose((pts[-2] - pts[-3]) / np.linalg.norm(pts[-2] - pts[-3]), out, atol=math.pi / TURN_SEGMENTS)
    # arc length: the straight parts plus the quarter circle, within the chords' shortfall
    arc = leave_s - before
    assert arc == pytest.approx(0.5 * math.pi * radius, rel=3e-4)
    assert arc < 0.5 * math.pi * radius
    assert path.length == pytest.approx(leave_s + after)


def test_turning_cars_draw_their_exit_uniformly_and_go_on_the_road_they_turn_into():
    env = box2d_driving.make("intersection-v0", turns=True, num_cars=4)
    counts = {0: 0, 1: 0, -1: 0}
    for seed in range(150):
        env.reset(seed=seed)
        layout = env.layout
        for car in layout.cars:
            d = DIRS[car.approach]
            end = car.path.points[-1]
            heading_out = car.path.points[-1] - car.path.points[-2]
            heading_out /= np.linalg.norm(heading_out)
            turn = int(round(float(d[0] * heading_out[1] - d[1] * heading_out[0])))
            counts[turn] += 1
            assert car.light_index == car.approach  # the lights: the road it comes from
            goal = car.goal if car.goal is not None else end
            # goal on the exit road, goal_fraction * L / 2 + W / 2 from the centre
            assert goal @ heading_out > 0 and abs(goal @ heading_out) > env.config.road_width_range[0] / 2
    total = sum(counts.values())
    for turn, n in counts.items():
        assert 0.28 < n / total < 0.39, counts  # 600 cars: 1/3 +- 4.5 standard errors


def test_without_turns_every_car_goes_straight_on():
    env = box2d_driving.make("intersection-v0", num_cars=4, preset="paper")
    for seed in range(20):
        env.reset(seed=seed)
        for car in env.layout.cars:
            assert len(car.path.points) == 2


def test_the_paper_worlds_goal_is_on_the_axis_of_the_road_turned_into():
    env = box2d_driving.make("intersection-v0", turns=True, num_cars=1, preset="paper")
    width_seen = 0
    for seed in range(60):
        env.reset(seed=seed)
        car = env.layout.cars[0]
        out = car.goal / np.linalg.norm(car.goal)
        assert abs(abs(out[0]) + abs(out[1]) - 1.0) < 1e-9  # along an axis: the road's
        # where the track reaches goal_s the car is goal_radius * W from the goal point
        width = 2 * float(np.abs(env.layout.junction_box[2]))
        pos, _ = car.path.pose(car.goal_s)
        assert np.linalg.norm(pos - car.goal) == pytest.approx(width / 3, abs=1e-6)
        width_seen += 1
    assert width_seen == 60


@pytest.mark.parametrize("overrides", [{}, {"preset": "paper"}])
def test_a_lone_car_at_full_throttle_arrives_whatever_its_turn(overrides):
    env = box2d_driving.make("intersection-v0", turns=True, num_cars=1, **overrides)
    top = env.action_space(env.possible_agents[0]).n - 1
    for seed in range(40):
        env.reset(seed=seed)
        arrived = False
        while env.agents:
            _, _, term, trunc, infos = env.step({a: top for a in env.agents})
            arrived |= any(info.get("arrived", False) for info in infos.values())
        arrived |= bool(env.world.has_arrived[0])
        assert arrived, seed


def test_the_timing_invariant_holds_with_turns():
    cfg = IntersectionConfig(turns=True)
    slack = 2 * cfg.decision_time
    assert cfg.worst_case_arrival_time() > IntersectionConfig().worst_case_arrival_time()
    assert cfg.worst_case_arrival_time() + slack <= cfg.horizon * cfg.decision_time


def _paper_code_turn(d, side, lane, half, before, out, speed, dt, steps):
    """The paper's code's turning motion (``_FixedTrackAccelerationModel.forward`` at constant
    speed), written out step by step: positions and distances driven after each step."""
    d, n = np.asarray(d, float), np.asarray(out, float)
    sign = d[0] * n[1] - d[1] * n[0]
    entry, centre = -half * d + lane * np.asarray(side, float), -half * d + half * n
    r = float(np.linalg.norm(entry - centre))
    theta1 = math.atan2(d[1], d[0])
    pos, theta, driven = entry - before * d, theta1, 0.0
    positions, distances = [], []
    for _ in range(steps):
        step = speed * dt
        driven += step
        arc = driven - before
        if 0.0 < arc < 0.5 * math.pi * r:  # read off the circle at the last step's heading
            pos = centre + sign * r * np.array([math.sin(theta), -math.cos(theta)])
        else:
            pos = pos + step * np.array([math.cos(theta), math.sin(theta)])
        theta = theta1 + sign * min(max(arc / (0.5 * math.pi * r + 1e-7), 0.0), 0.5 * math.pi)
        positions.append(pos.copy())
        distances.append(driven)
    return np.array(positions), np.array(distances)


TURN_CASES = [((1.0, 0.0), (0.0, 1.0), (0.0, 1.0)), ((1.0, 0.0), (0.0, 1.0), (0.0, -1.0)),
              ((0.0, 1.0), (-1.0, 0.0), (1.0, 0.0)), ((-1.0, 0.0), (0.0, -1.0), (0.0, 1.0))]


@pytest.mark.parametrize("d,side,out", TURN_CASES)
@pytest.mark.parametrize("lane,half", [(1.5, 7.5), (4.5, 15.0), (3.0, 10.0)])
def test_the_paper_turn_is_the_limit_of_the_paper_codes_steps(d, side, out, lane, half):
    from box2d_driving.road.turns import paper_turning_track

    d, side, out = (np.array(v) for v in (d, side, out))
    path = paper_turning_track(d, side, lane, half, 20.0, out, half + 60.0)
    # short steps: the same curve (the chords' error and one 8 mm step of lag)
    pos, driven = _paper_code_turn(d, side, lane, half, 20.0, out, 8.0, 0.001, int((path.length - 1) / 0.008))
    assert np.abs(path.pose(driven)[0] - pos).max() < 0.01
    # the paper's 0.1 s steps: its position lags ours by up to one step (0.8 m at 8 m/s) driven,
    # read off the circle at 2/pi of it; a wrong curve would be metres off
    pos, driven = _paper_code_turn(d, side, lane, half, 20.0, out, 8.0, 0.1, int((path.length - 1) / 0.8))
    gap = np.abs(path.pose(driven)[0] - pos).max()
    assert 0.3 < gap < 0.55
    # the heading: one radian turned where the circle part ends, then on round to the new road
    _, heading = path.pose(np.array([path.cumlen[1] + 0.5 * math.pi * np.linalg.norm(
        (-half * d + lane * side) - (-half * d + half * out)) - 1e-6, path.length - 1e-6]))
    sign = d[0] * out[1] - d[1] * out[0]
    theta1 = math.atan2(d[1], d[0])
    assert abs(math.remainder(heading[0] - (theta1 + sign * 1.0), 2 * math.pi)) < 0.05
    assert abs(math.remainder(heading[1] - math.atan2(out[1], out[0]), 2 * math.pi)) < 1e-9


def test_the_paper_turning_world_arrives_where_the_goal_test_first_passes():
    env = box2d_driving.make("intersection-v0", preset="paper-turns", num_cars=1)
    turning = 0
    for seed in range(40):
        env.reset(seed=seed)
        car = env.layout.cars[0]
        if len(car.path.points) == 2:
            continue
        turning += 1
        width = 2 * float(env.layout.junction_box[2])
        pos, _ = car.path.pose(car.goal_s)
        if car.goal_s <= car.path.length:
            assert np.linalg.norm(pos - car.goal) == pytest.approx(width / 3, abs=0.02)
            before, _ = car.path.pose(np.arange(car.path.cumlen[1], car.goal_s - 0.02, 0.05))
            assert (np.linalg.norm(before - car.goal, axis=1) > width / 3).all()
    assert turning > 15


@pytest.mark.parametrize("share,low,high", [(0.0, 0.0, 0.0), (1.0, 1.0, 1.0), (0.125, 0.10, 0.15)])
def test_the_first_green_share_of_the_lights(share, low, high):
    from box2d_driving.road.lights import sample_lights

    rng = np.random.default_rng(0)
    stops, dirs = np.zeros((4, 2)), np.eye(2)[[0, 1, 0, 1]]
    starts = [sample_lights(rng, stops, dirs, np.arange(4) % 2, (10.0, 15.0), 1.0, "green_or_red", 0.1, share).offset
              for _ in range(2000)]
    green = np.mean(np.asarray(starts) == 0.0)
    assert low <= green <= high


def test_an_even_first_green_share_draws_as_before():
    from box2d_driving.road.lights import sample_lights

    a, b = np.random.default_rng(7), np.random.default_rng(7)
    for _ in range(50):
        lights = sample_lights(a, np.zeros((4, 2)), np.eye(2)[[0, 1, 0, 1]], np.arange(4) % 2, (10.0, 15.0), 1.0,
                               "green_or_red", 0.1)
        half = float(np.floor(b.uniform(10.0, 15.0) / 0.1) * 0.1)
        assert lights.offset == half * b.integers(2)


def test_bad_turn_settings_are_refused_by_name():
    from box2d_driving.config import ConfigError

    with pytest.raises(ConfigError, match="turn_motion must be one of"):
        box2d_driving.make("intersection-v0", turns=True, turn_motion="spiral")
    with pytest.raises(ConfigError, match="needs goal_radius"):
        box2d_driving.make("intersection-v0", turns=True, turn_motion="paper")
    with pytest.raises(ConfigError, match="light_first_green"):
        box2d_driving.make("intersection-v0", light_first_green=1.5)


hypothesis = pytest.importorskip("hypothesis")
from hypothesis import given, settings, strategies as st  # noqa: E402


@settings(max_examples=60, deadline=None, derandomize=True, database=None)
@given(st.integers(0, 3), st.sampled_from([1.0, -1.0]), st.sampled_from([1, -1]), st.floats(7.5, 15.0),
       st.floats(0.05, 0.45), st.floats(0.5, 60.0), st.floats(1.0, 80.0))
def test_any_turning_track_is_continuous_and_ends_down_the_new_road(approach, side_sign, turn, half, lane_share,
                                                                  before, after):
    from box2d_driving.road.turns import paper_turning_track

    d = DIRS[approach]
    side, out = side_sign * _right(d), exit_direction(d, turn)
    lane = lane_share * 2 * half
    circle, _ = turning_track(d, side, lane, half, before, out, after)
    paper = paper_turning_track(d, side, lane, half, before, out, half + 30.0 + after)
    for path in (circle, paper):
        assert np.allclose(path.points[0], -half * d + lane * side - before * d)
        steps = np.diff(path.cumlen)
        chords = np.linalg.norm(np.diff(path.points, axis=0), axis=1)
        assert (steps > 0).all() and (steps >= chords - 1e-9).all()  # what _first_within relies on
        assert (chords[1:-1] < 2.0).all()  # the turn itself in short chords
        end = path.points[-1] - path.points[-2]
        assert np.allclose(end / np.linalg.norm(end), out, atol=1e-9)
    assert np.allclose(circle.cumlen, np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(
        circle.points, axis=0), axis=1))]))  # the circle's track is driven at its geometry
    assert paper.points[-1] @ out == pytest.approx(half + 30.0 + after)
