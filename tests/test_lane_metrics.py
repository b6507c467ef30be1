"""Lane and fast-lane metrics on hand-built rollout tables."""

import numpy as np
import pytest

from box2d_driving.metrics.lanes import crossing_sides, fast_lane_metrics, lane_metrics, pearson
from tests.helpers import table_from_rows as _table


LANE_COLS = ("episode", "car", "decision", "in_junction", "lane_offset")


def test_crossing_sides_average_only_inside_the_junction():
    rows = [
        (0, 0, 0, 0, -0.9),  # outside: ignored
        (0, 0, 1, 1, 0.2), (0, 0, 2, 1, 0.4),   # crossing 1: mean +0.3 (right)
        (0, 1, 1, 1, -0.5),                      # crossing 2: left
        (1, 0, 1, 1, 0.6), (1, 0, 2, 1, -0.2),  # crossing 3: +0.2 (right)
        (1, 1, 3, 0, 0.9),                       # never inside: no crossing
    ]
    t = _table(rows, LANE_COLS)
    assert sorted(crossing_sides(t).round(9)) == [-0.5, 0.2, 0.3]
    m = lane_metrics(t, bins=4)
    assert m["crossings"] == 3 and m["majority_side"] == "right"
    assert m["majority_share"] == pytest.approx(2 / 3)
    assert m["time_share_majority"] == pytest.approx(3 / 5)  # 0.2, 0.4, 0.6 of 5 inside samples
    assert m["histogram"] == [0, 2, 2, 1]  # bins [-1,-.5) [-.5,0) [0,.5) [.5,1]
    # inside samples 0.2, 0.4, -0.5, 0.6, -0.2: |mean| 0.1, mean |.| 0.38
    assert m["one_sided_offset"] == pytest.approx(0.1)
    assert m["mean_abs_lane_position"] == pytest.approx(0.38)


def test_one_sided_offset_is_the_offset_when_every_car_keeps_to_one_side_and_zero_across_the_axis():
    left = lane_metrics(_table([(0, 0, 1, 1, -0.3), (0, 1, 1, 1, -0.5)], LANE_COLS))
    assert left["one_sided_offset"] == pytest.approx(0.4) == left["mean_abs_lane_position"]
    both = lane_metrics(_table([(0, 0, 1, 1, -0.4), (0, 1, 1, 1, 0.4)], LANE_COLS))
    assert both["one_sided_offset"] == pytest.approx(0.0) and both["mean_abs_lane_position"] == pytest.approx(0.4)


def test_lane_metrics_left_majority_and_axis_crossings():
    rows = [(0, 0, 1, 1, -0.4), (0, 1, 1, 1, -0.3), (0, 2, 1, 1, 0.0), (0, 3, 1, 1, 0.5)]
    m = lane_metrics(_table(rows, LANE_COLS))
    assert m["majority_side"] == "left"
    assert m["crossings_left"] == 2 and m["crossings_right"] == 1
    assert m["majority_share"] == pytest.approx(0.5)  # the axis crossing counts for neither side


def test_lane_metrics_without_crossings_is_nan():
    m = lane_metrics(_table([(0, 0, 1, 0, 0.3)], LANE_COLS))
    assert m["crossings"] == 0 and np.isnan(m["majority_share"])


def test_fast_lane_metrics_use_each_cars_last_position():
    cols = ("episode", "car", "decision", "rating", "y")
    w = 20.0
    rows = []
    for car, (rating, y_end) in enumerate([(0.5, -6.0), (0.6, -2.0), (0.9, 4.0), (1.0, 8.0)]):
        rows += [(0, car, 0, rating, 0.0), (0, car, 5, rating, y_end)]
    t = _table(rows, cols)
    m = fast_lane_metrics(t, road_width=w)
    lateral = np.array([-0.6, -0.2, 0.4, 0.8])
    assert m["cars"] == 4
    assert m["pearson_r"] == pytest.approx(np.corrcoef([0.5, 0.6, 0.9, 1.0], lateral)[0, 1])
    assert m["fast_half_mean_lateral"] == pytest.approx(0.6)
    assert m["slow_half_mean_lateral"] == pytest.approx(-0.4)
    assert m["fast_side"] == "left"


def test_pearson_is_nan_for_constant_input():
    assert np.isnan(pearson([1, 1, 1], [1, 2, 3]))
    assert pearson([1, 2, 3], [3, 2, 1]) == pytest.approx(-1.0)
