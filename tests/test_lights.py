"""Traffic light cycle and visibility rule."""

import numpy as np
import box2d_driving
from box2d_driving.road.lights import GREEN, NO_LIGHT, RED, YELLOW, TrafficLights
from tests.helpers import hand_env, straight_car


def make_lights(offset=0.0, half_period=12.0):
    return TrafficLights(
        stop_points=np.array([[0.0, 0.0], [0.0, 0.0]]),
        directions=np.array([[1.0, 0.0], [0.0, 1.0]]),
        groups=np.array([0, 1]), half_period=half_period, yellow=1.0, offset=offset,
    )


def test_cycle_timing_and_antiphase():
    lights = make_lights()
    expect0 = {0.0: GREEN, 10.9: GREEN, 11.0: YELLOW, 11.9: YELLOW, 12.0: RED, 22.9: RED,
               23.0: YELLOW, 23.9: YELLOW, 24.0: GREEN, 35.5: YELLOW}
    expect1 = {0.0: RED, 10.9: RED, 11.0: YELLOW, 12.0: GREEN, 22.9: GREEN, 23.0: YELLOW, 24.0: RED}
    for t, v in expect0.items():
        assert lights.values(t)[0] == v, t
    for t, v in expect1.items():
        assert lights.values(t)[1] == v, t
    for t in np.arange(0, 48, 0.1):
        v = lights.values(t)
        assert not (v[0] == GREEN and v[1] == GREEN)
        assert not (v[0] == RED and v[1] == RED)


def test_start_phase_offset():
    assert make_lights(offset=12.0).values(0.0)[0] == RED


def test_episode_lights_are_sampled_in_range():
    env = box2d_driving.make("intersection-v0")
    periods, offsets = [], []
    for seed in range(200):
        env.reset(seed=seed)
        periods.append(env.layout.lights.half_period)
        offsets.append(env.layout.lights.offset / (2 * env.layout.lights.half_period))
    assert 10.0 <= min(periods) and max(periods) < 15.0
    assert 0.0 <= min(offsets) and max(offsets) < 1.0
    assert np.std(offsets) > 0.2  # spread over the cycle


def _seen(lights, pos, heading):
    return lights.seen(0.0, np.array([0]), np.array([pos], float), np.array([heading]), 30.0)[0]


def test_visibility_before_and_after_stop_line_and_facing():
    lights = make_lights()
    assert _seen(lights, (-20, 0), 0.0) == GREEN
    assert _seen(lights, (-29.9, 0), 0.0) == GREEN
    assert _seen(lights, (-30.5, 0), 0.0) == NO_LIGHT  # too far
    assert _seen(lights, (0.5, 0), 0.0) == NO_LIGHT  # passed the light
    assert _seen(lights, (-20, 0), np.pi) == NO_LIGHT  # facing away
    assert _seen(lights, (-20, 0), 1.4) == GREEN  # still facing (within 90 degrees)
    none = lights.seen(0.0, np.array([-1]), np.array([[-5.0, 0.0]]), np.array([0.0]), 30.0)
    assert none[0] == NO_LIGHT


def test_car_in_env_sees_its_light_then_loses_it():
    env = box2d_driving.make("intersection-v0", num_cars=1)
    obs, info = env.reset(seed=4)
    lay = env.observation_layout
    up = len(env.config.accelerations) - 1
    history = []
    while env.agents:
        obs, _, _, _, info = env.step({"car_0": up})
        i = info["car_0"]
        stop_dist = (env.layout.lights.stop_points[0] - i["position"]) @ env.layout.lights.directions[0]
        expected = (env.layout.lights.values(env.time)[0] if 0 < stop_dist <= 30 else NO_LIGHT)
        assert i["light"] == expected
        _, satnav = lay.split(obs["car_0"])
        assert satnav[-1, lay.field("light")] == expected
        history.append(expected)
    assert history[-1] == NO_LIGHT
    assert any(v in (GREEN, YELLOW, RED) for v in history)


def test_hand_built_light_visible_only_to_its_approach():
    lights = make_lights()
    cars = [straight_car((-20, 0), (40, 0), light_index=0), straight_car((-20, -5), (40, -5))]
    env = hand_env(cars, layout_kw={"lights": lights})
    obs, info = env.reset(seed=0)
    assert info["car_0"]["light"] == GREEN
    assert info["car_1"]["light"] == NO_LIGHT


def test_lights_of_several_junctions_at_once_are_each_junctions_own_to_the_bit():
    """seen_by_cars (the env core's batched rule) against TrafficLights.seen, junction by junction,
    over random cars around the stop lines (with and without a light) at random times."""
    from box2d_driving.road.lights import seen_by_cars

    rng = np.random.default_rng(0)
    junctions = [TrafficLights(rng.uniform(-5, 5, (4, 2)), np.array([[1.0, 0], [0, 1], [-1, 0], [0, -1]]),
                               np.array([0, 1, 0, 1]), float(rng.uniform(10, 15)), 1.0, float(rng.uniform(0, 20)))
                 for _ in range(3)]
    cols = {k: [] for k in ("time", "stop", "dir", "group", "period", "yellow", "offset", "pos", "head")}
    want = []
    for _ in range(200):
        for lights in junctions:
            t = float(rng.uniform(0, 60))
            li = rng.integers(-1, 4, 5)
            pos = lights.stop_points[np.maximum(li, 0)] + rng.uniform(-35, 35, (5, 2))
            head = rng.uniform(-np.pi, np.pi, 5)
            want.append(lights.seen(t, li, pos, head, 30.0))
            has = li >= 0
            cols["time"].append(np.full(5, t))
            cols["stop"].append(np.where(has[:, None], lights.stop_points[np.maximum(li, 0)], np.nan))
            cols["dir"].append(np.where(has[:, None], lights.directions[np.maximum(li, 0)], np.nan))
            cols["group"].append(np.where(has, lights.groups[np.maximum(li, 0)], 0))
            cols["period"].append(np.full(5, lights.half_period))
            cols["yellow"].append(np.full(5, lights.yellow))
            cols["offset"].append(np.full(5, lights.offset))
            cols["pos"].append(pos)
            cols["head"].append(head)
    c = {k: np.concatenate(v) for k, v in cols.items()}
    got = seen_by_cars(c["time"], c["stop"], c["dir"], c["group"], c["period"], c["yellow"], c["offset"],
                       c["pos"], c["head"], 30.0)
    want = np.concatenate(want)
    assert np.array_equal(got, want)
    assert len(set(want.tolist())) == 4  # green, yellow, red and no light all occurred


def test_plain_values_are_the_array_values_to_the_bit():
    from box2d_driving.road.lights import sample_lights

    rng = np.random.default_rng(0)
    for _ in range(500):
        lights = sample_lights(rng, rng.normal(size=(4, 2)), rng.normal(size=(4, 2)), np.arange(4) % 2,
                               (5.0, 30.0), float(rng.uniform(0.0, 4.0)))
        t, y, off = lights.half_period, lights.yellow, lights.offset
        # random times and the phase boundaries themselves, where a rounding difference would show
        for time in rng.uniform(0.0, 500.0, size=10).tolist() + [0.0, t - off, t - y - off, 2 * t - y - off]:
            assert lights.plain_values(time) == lights.values(time).tolist()
