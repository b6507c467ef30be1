"""Spawns never overlap; the intersection timing invariant holds."""

import math

import numpy as np
import pytest

import box2d_driving
from tests.helpers import hand_env, straight_car
from box2d_driving.envs.intersection import IntersectionConfig
from box2d_driving.physics.kinematics import advance_speed
from box2d_driving.road.geometry import rectangle_corners, rectangles_overlap


def _max_cars(env_id):
    return box2d_driving.make(env_id).config.max_cars()


@pytest.mark.parametrize("env_id", ["intersection-v0", "highway-v0", "crosswalk-v0"])
def test_spawns_never_overlap_over_1000_seeded_resets(env_id):
    env = box2d_driving.make(env_id, num_cars=_max_cars(env_id))
    cfg = env.config
    for seed in range(1000):
        env.reset(seed=seed)
        w = env.world
        rects = [rectangle_corners(*w.positions[i], w.headings[i], cfg.car_length, cfg.car_width)
                 for i in range(cfg.num_cars)]
        size = getattr(cfg, "pedestrian_size", 0.8)
        rects += [rectangle_corners(*p, 0.0, size, size) for p in w.ped_positions]
        for i in range(len(rects)):
            for j in range(i + 1, len(rects)):
                assert not rectangles_overlap(rects[i], rects[j]), (seed, i, j)
        # and every car is on the road, behind its goal
        assert np.all(w.s_end > 0)


def test_overlap_checker_detects_overlap():
    a = rectangle_corners(0, 0, 0.0, 4.48, 2.2)
    assert rectangles_overlap(a, rectangle_corners(4.0, 0.5, 0.3, 4.48, 2.2))
    assert not rectangles_overlap(a, rectangle_corners(4.6, 0.0, 0.0, 4.48, 2.2))


def test_intersection_timing_invariant_holds_for_defaults():
    cfg = IntersectionConfig()
    slack = 2 * cfg.decision_time  # control is held for a whole decision in each phase
    assert cfg.worst_case_arrival_time() + slack <= cfg.horizon * cfg.decision_time


def test_paper_horizon_would_break_the_invariant():
    cfg = IntersectionConfig(horizon=25)
    assert cfg.worst_case_arrival_time() > cfg.horizon * cfg.decision_time


def _decision(v, a, cfg):
    s = 0.0
    for _ in range(cfg.substeps):
        ds, v = advance_speed(v, a, cfg.v_lim, cfg.dt)
        s += ds
    return s, v


def test_worst_case_is_achievable_by_a_scripted_driver():
    """In the env, with whole-decision control: a car from the farthest slot on the largest map
    stops at the line, waits a full red, then drives on, and still reaches its goal in time."""
    cfg = IntersectionConfig()
    d_stop = cfg.farthest_spawn()
    d_goal = cfg.road_width_range[1] + 0.5 * cfg.goal_fraction * cfg.road_length_range[1]
    env = hand_env([straight_car((0, 0), (d_stop + d_goal, 0))], horizon=cfg.horizon)
    env.reset(seed=0)
    levels = np.asarray(cfg.accelerations)
    a_max = levels.max()
    red = math.ceil(cfg.light_period_range[1] - cfg.light_yellow)
    waited = 0
    while env.agents:
        w = env.world
        s_left, v = d_stop - w.s[0], w.speed[0]
        if waited >= red:
            level = a_max
        elif v == 0.0 and s_left < 1.0:
            level, waited = 0.0, waited + 1
        else:  # the fastest level after which the car can still stop before the line
            level = levels[0]
            for cand in levels[::-1]:
                ds, v1 = _decision(v, cand, cfg)
                if ds + v1 * v1 / (2 * a_max) <= s_left:
                    level = cand
                    break
        _, _, term, trunc, info = env.step({"car_0": int(np.argmin(np.abs(levels - level)))})
    assert waited == red
    assert info["car_0"]["arrived"], info["car_0"]
