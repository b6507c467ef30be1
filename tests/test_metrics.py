"""Metric functions on hand-built trajectories, and on scripted policies."""

import numpy as np
import pytest

import box2d_driving
from box2d_driving.metrics.lights import (junction_entries, outcome_rates, traffic_light_metrics, violation_causes,
                                         violation_rate)
from box2d_driving.metrics.rollouts import (COLUMNS, RolloutRecorder, load_table, row_lookup, run_episodes,
                                            save_table)
from box2d_driving.policies import LightRulePolicy, RandomPolicy


def _table(rows):
    """rows: (episode, car, decision, light, in_junction, arrived, collided)."""
    n = len(rows)
    t = {c: np.zeros(n) for c in COLUMNS}
    ep, car, dec, light, inside, arrived, collided = map(np.array, zip(*rows))
    t.update(episode=ep.astype(int), car=car.astype(int), decision=dec.astype(int), light=light,
             in_junction=inside.astype(bool), arrived=arrived.astype(bool),
             collided=collided.astype(bool))
    return t


def test_entry_light_is_the_one_seen_before_entering():
    rows = [
        # car 0 sees 1.0 then 0.0 and enters on 0.0 at decision 3
        (0, 0, 0, 0.75, 0, 0, 0), (0, 0, 1, 1.0, 0, 0, 0), (0, 0, 2, 0.0, 0, 0, 0),
        (0, 0, 3, 0.75, 1, 0, 0), (0, 0, 4, 0.75, 0, 1, 0),
        # car 1 enters on 1.0 (a violation if 1.0 is stop)
        (0, 1, 0, 1.0, 0, 0, 0), (0, 1, 1, 1.0, 1, 0, 0), (0, 1, 2, 0.75, 1, 0, 1),
        # car 2 never enters
        (0, 2, 0, 1.0, 0, 0, 0), (0, 2, 1, 1.0, 0, 0, 0),
    ]
    t = _table(rows[::-1])  # order must not matter
    e = junction_entries(t)
    got = sorted(zip(e["car"].tolist(), e["light"].tolist(), e["decision"].tolist()))
    assert got == [(0, 0.0, 3), (1, 1.0, 1)]


def test_a_violation_is_the_worlds_when_the_car_was_inside_its_braking_distance_as_the_light_changed():
    # braking at 1.5 m/s^2 (rating 1) from 10 m/s takes 33.3 m, from 5 m/s 8.3 m
    def car(c, lights, speeds, dists, enter_at):
        return [(0, c, d, light, d >= enter_at, v, x) for d, (light, v, x) in enumerate(zip(lights, speeds, dists))]

    rows = (
        # green until 20 m before the line at 10 m/s: yellow, then red, enters: could not stop
        car(0, [0.75, 0.0, 0.5, 1.0, 0.75], [10, 10, 10, 10, 10], [50, 30, 20, 10, 0], 4)
        # the same change 20 m before the line at 5 m/s: room to stop, entered anyway
        + car(1, [0.0, 0.5, 1.0, 1.0, 0.75], [5, 5, 5, 5, 5], [25, 20, 15, 5, -5], 4)
        # came into view on red 30 m before the line at 10 m/s: could not stop
        + car(2, [0.75, 1.0, 1.0, 0.75], [10, 10, 10, 10], [40, 30, 10, 0], 3)
        # saw red, then green, then red again 9 m before the line at 5 m/s: the last run counts (room)
        + car(3, [1.0, 0.0, 1.0, 0.75], [5, 5, 5, 5], [30, 20, 9, -2], 3)
        # enters on green: not a violation
        + car(4, [0.0, 0.0, 0.75], [10, 10, 10], [20, 10, 0], 2)
        # no stop line on its approach: unknown
        + car(5, [1.0, 1.0, 0.75], [5, 5, 5], [np.nan, np.nan, np.nan], 2)
        # more entries on green than on red, so that red is the adopted stop value
        + sum((car(c, [0.0, 0.0, 0.75], [10, 10, 10], [20, 10, 0], 2) for c in range(6, 11)), [])
    )
    n = len(rows)
    t = {c: np.zeros(n) for c in COLUMNS}
    ep, c, dec, light, inside, speed, dist = map(np.array, zip(*rows))
    t.update(episode=ep.astype(int), car=c.astype(int), decision=dec.astype(int), light=light,
             in_junction=inside.astype(bool), speed=speed.astype(float), stop_line_distance=dist.astype(float),
             rating=np.ones(n), arrived=np.zeros(n, bool), collided=np.zeros(n, bool))
    flip = np.arange(n)[::-1]
    t = {k: v[flip] for k, v in t.items()}  # order must not matter
    got = violation_causes(t, 1.0, 1.5)
    assert (got.violations, got.could_not_stop, got.could_have_stopped, got.unknown) == (5, 2, 2, 1)
    # a car rated 0.5 brakes at 0.75 m/s^2: car 1 (5 m/s, 20 m: needs 16.7 m) still could, car 3 (9 m) not
    t["rating"] = np.full(n, 0.5)
    got = violation_causes(t, 1.0, 1.5)
    assert (got.could_not_stop, got.could_have_stopped) == (3, 1)
    # the shares of all entries sum with the unknown ones to the violation rate
    t["rating"] = np.ones(n)
    m = traffic_light_metrics(t, max_brake=1.5)
    assert m["stop_value"] == 1.0 and m["junction_entries"] == 11
    assert m["violations_could_not_stop_rate"] == 2 / 11 and m["violations_could_have_stopped_rate"] == 2 / 11
    assert m["violations_unknown_cause"] == 1 and m["red_light_violation_rate"] == 5 / 11
    assert m["violators_collision_rate"] == 0.0
    t["collided"] = (t["car"] == 2) & (t["decision"] == 3)  # car 2 (a violator) ends collided
    assert traffic_light_metrics(t, max_brake=1.5)["violators_collision_rate"] == 1 / 5
    assert "violations_could_not_stop_rate" not in traffic_light_metrics(t)
    with pytest.raises(ValueError, match="max_brake"):
        violation_causes(t, 1.0, 0.0)


def test_violation_rate_adopts_the_rarer_value_as_stop():
    v = violation_rate(np.array([0.0] * 9 + [1.0] * 1 + [0.5] * 2))
    assert v.stop_value == 1.0 and v.rate == pytest.approx(1 / 12) and v.entries == 12
    v = violation_rate(np.array([1.0] * 8 + [0.0] * 2))
    assert v.stop_value == 0.0 and v.rate == pytest.approx(0.2)
    assert np.isnan(violation_rate(np.array([])).rate)


def test_outcome_rates_use_each_cars_last_row():
    rows = [(0, 0, 0, 0, 0, 0, 0), (0, 0, 5, 0, 0, 1, 0), (0, 1, 0, 0, 0, 0, 0),
            (0, 1, 2, 0, 0, 0, 1), (1, 0, 0, 0, 0, 0, 0), (1, 0, 9, 0, 0, 0, 0)]
    r = outcome_rates(_table(rows))
    assert r["cars"] == 3
    assert r["success_rate"] == pytest.approx(1 / 3) and r["collision_rate"] == pytest.approx(1 / 3)
    assert r["mean_time_to_goal"] == 5


def test_row_lookup_finds_rows_and_reports_missing_ones():
    rows = [(0, 0, 0, 0, 0, 0, 0), (0, 0, 5, 0, 0, 1, 0), (0, 1, 0, 0, 0, 0, 0),
            (0, 1, 2, 0, 0, 0, 1), (1, 0, 0, 0, 0, 0, 0), (1, 0, 9, 0, 0, 0, 0)]
    t = _table(rows[::-1])  # any row order
    find = row_lookup(t)
    assert int(find(0, 1, 2)) == 2 and int(find(1, 0, 9)) == 0
    np.testing.assert_array_equal(find([0, 0, 1], [0, 1, 0], [5, 0, 0]), [4, 3, 1])
    # absent: decision 1 of car 0; car 2, car -1 and decision 10 (out of range, no aliasing)
    np.testing.assert_array_equal(find([0, 0, 0, 1, 2], [0, 2, -1, 0, 0], [1, 0, 0, 10, 0]), [-1] * 5)
    empty = row_lookup({k: v[:0] for k, v in t.items()})
    assert int(empty(0, 0, 0)) == -1


def test_hand_rule_obeys_lights_and_random_does_not(tmp_path):
    env = box2d_driving.make("intersection-v0", num_cars=4)
    rule = traffic_light_metrics(run_episodes(env, LightRulePolicy(env), 30, seed=0))
    rand_table = run_episodes(env, RandomPolicy(env, seed=0), 30, seed=0)
    rand = traffic_light_metrics(rand_table)
    assert rule["red_light_violation_rate"] < 0.1 and rule["stop_value"] == 1.0
    assert rule["success_rate"] > 0.85 and rule["collision_rate"] < 0.1
    assert 0.3 < rand["red_light_violation_rate"] < 0.6
    save_table(rand_table, tmp_path / "r.npz")
    back = load_table(tmp_path / "r.npz")
    assert set(COLUMNS) <= set(back) and len(back["x"]) == len(rand_table["x"])


def test_recorder_rows_match_decisions():
    env = box2d_driving.make("intersection-v0", num_cars=2, horizon=5)
    rec = RolloutRecorder()
    table = run_episodes(env, RandomPolicy(env, seed=1), 2, recorder=rec)
    for ep in (0, 1):
        for car in (0, 1):
            d = table["decision"][(table["episode"] == ep) & (table["car"] == car)]
            assert d[0] == 0 and np.all(np.diff(d) == 1)


@pytest.mark.parametrize("stop_value", [0.0, 1.0])
def test_acceleration_by_light_keeps_each_values_colour_whatever_the_stop_value(tmp_path, monkeypatch, stop_value):
    import matplotlib
    from matplotlib.colors import to_rgba

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from training.evaluation import plots

    figures = []
    monkeypatch.setattr(plt, "close", lambda fig=None: figures.append(fig))
    n = 60
    table = {"episode": np.zeros(n, int), "car": np.repeat([0, 1, 2], n // 3),
             "decision": np.tile(np.arange(n // 3), 3), "light": np.tile([0.0, 0.5, 1.0], n // 3),
             "stop_line_distance": np.linspace(1, 45, n), "acceleration": np.linspace(-1, 1, n)}
    plots.acceleration_by_light(table, tmp_path / "a.png", stop_value=stop_value)
    legend = figures[0].axes[0].get_legend()
    labels = {t.get_text(): to_rgba(h.get_color()) for t, h in zip(legend.get_texts(), legend.legend_handles)}
    stop_label = f"light {stop_value} (stop)"
    assert labels[stop_label][:3] == to_rgba(plots.LIGHT_VALUE_COLOURS[stop_value])[:3]
    go = 1.0 - stop_value
    assert labels[f"light {go} (go)"][:3] == to_rgba(plots.LIGHT_VALUE_COLOURS[go])[:3]


def test_acceleration_by_light_drops_empty_distance_bins_and_shows_flat_boxes_in_colour(tmp_path, monkeypatch):
    import matplotlib
    from matplotlib.colors import to_rgba

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from training.evaluation import plots

    figures = []
    monkeypatch.setattr(plt, "close", lambda fig=None: figures.append(fig))
    n = 30  # every car within 25 m of its line, every acceleration the same: no spread at all
    table = {"episode": np.zeros(n, int), "car": np.repeat([0, 1, 2], n // 3),
             "decision": np.tile(np.arange(n // 3), 3), "light": np.tile([0.0, 1.0, 1.0], n // 3),
             "stop_line_distance": np.linspace(1, 25, n), "acceleration": np.full(n, 1.5)}
    plots.acceleration_by_light(table, tmp_path / "a.png", stop_value=1.0)
    ax = figures[0].axes[0]
    assert [t.get_text() for t in ax.get_xticklabels()] == ["0-10 m", "10-20 m", "20-30 m"]  # no 30-50 m
    dots = [tuple(c) for col in ax.collections for c in col.get_facecolors()]
    assert to_rgba(plots.LIGHT_VALUE_COLOURS[1.0]) in dots and to_rgba(plots.LIGHT_VALUE_COLOURS[0.0]) in dots
