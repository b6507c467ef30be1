"""Right of way (FIFO), safe following distance and communication metrics on hand-built tables."""

import math

import numpy as np
import pytest

from box2d_driving.metrics.communication import (average_ranks, communication_metrics, mutual_information,
                                                 rank_trend)
from box2d_driving.metrics.right_of_way import (fifo_metrics, fifo_violations, junction_times,
                                                 leader_samples, safety_distance_metrics)
from tests.helpers import table_from_rows


def inside_rows(episode, car, pattern):
    """Rows of one car: ``pattern`` is a string of 0/1 per decision (1 = inside the junction)."""
    return [(episode, car, t, int(c)) for t, c in enumerate(pattern)]


COLS = ("episode", "car", "decision", "in_junction")


def test_junction_times_first_entry_first_exit_and_never_leaving():
    rows = inside_rows(0, 0, "00110") + inside_rows(0, 1, "0111") + inside_rows(0, 2, "000")
    t = junction_times(table_from_rows(rows, COLS))
    assert t["car"].tolist() == [0, 1]  # car 2 never entered
    assert t["t_a"].tolist() == [2.0, 1.0]
    assert t["t_d"].tolist() == [4.0, math.inf]  # car 1's trajectory ends inside


def test_fifo_violation_needs_a_later_entry_leaving_earlier():
    # car 0 enters at 1, leaves at 5; car 1 enters at 2, leaves at 3 -> car 0 overtaken
    assert fifo_violations([1, 2], [5, 3]).tolist() == [True, False]
    # same entry decision: never ordered, so no violation
    assert fifo_violations([1, 1], [5, 3]).tolist() == [False, False]
    # in order
    assert fifo_violations([1, 2, 3], [4, 5, 6]).tolist() == [False, False, False]


def test_fifo_metrics_overall_and_per_episode():
    rows = (inside_rows(0, 0, "0111110") + inside_rows(0, 1, "0011000")  # ep 0: car 0 violated
            + inside_rows(1, 0, "0110") + inside_rows(1, 1, "00110"))  # ep 1: in order
    m = fifo_metrics(table_from_rows(rows, COLS))
    assert m["cars_through_junction"] == 4
    assert m["fifo_share"] == pytest.approx(3 / 4)
    assert m["fifo_share_episode_mean"] == pytest.approx((0.5 + 1.0) / 2)
    assert m["fifo_share_episode_std"] == pytest.approx(0.25)
    assert m["fifo_share_leaving"] == pytest.approx(3 / 4) and m["cars_leaving_junction"] == 4


def test_the_two_fifo_readings_differ_where_a_car_never_leaves():
    # car 0 enters first and stays inside (a wreck); cars 1 and 2 enter later and leave in order
    rows = inside_rows(0, 0, "011111") + inside_rows(0, 1, "001100") + inside_rows(0, 2, "000110")
    m = fifo_metrics(table_from_rows(rows, COLS))
    # every car that entered: car 0 is overtaken by both (it never leaves: t_d infinite)
    assert m["cars_through_junction"] == 3 and m["fifo_share"] == pytest.approx(2 / 3)
    # only the cars that left: cars 1 and 2, in order
    assert m["cars_leaving_junction"] == 2 and m["fifo_share_leaving"] == 1.0


SAFE_COLS = ("episode", "car", "decision", "x", "y", "heading", "speed")


def test_leader_gap_and_closing_speed():
    rows = [
        (0, 0, 1, 0.0, 0.0, 0.0, 8.0),    # follower at 8 m/s
        (0, 1, 1, 14.48, 0.0, 0.0, 2.0),  # leader 14.48 m ahead (gap 10 m), at 2 m/s
        (0, 2, 1, 5.0, 20.0, 0.0, 8.0),   # far to the side: not within 30 degrees of car 0
    ]
    s = leader_samples(table_from_rows(rows, SAFE_COLS), car_length=4.48)
    i = s["row"].tolist().index(0)
    assert s["gap"][i] == pytest.approx(10.0)
    assert s["closing_speed"][i] == pytest.approx(6.0)
    assert 1 not in s["row"].tolist()  # car 1 has nobody ahead within 30 degrees


def test_an_oncoming_car_is_not_a_leader():
    rows = [(0, 0, 1, 0.0, 0.0, 0.0, 8.0), (0, 1, 1, 20.0, 3.5, np.pi, 8.0)]  # next lane, other way
    assert len(leader_samples(table_from_rows(rows, SAFE_COLS), car_length=4.48)["row"]) == 0


def test_safety_share_uses_v2_over_2a():
    # closing 6 m/s, a_max 1.5 -> needs 12 m; gap 10 m unsafe, 13 m safe; an opening pair is ignored
    rows = [(0, 0, 1, 0.0, 0.0, 0.0, 8.0), (0, 1, 1, 14.48, 0.0, 0.0, 2.0),
            (1, 0, 1, 0.0, 0.0, 0.0, 8.0), (1, 1, 1, 17.48, 0.0, 0.0, 2.0),
            (2, 0, 1, 0.0, 0.0, 0.0, 2.0), (2, 1, 1, 6.0, 0.0, 0.0, 8.0)]
    m = safety_distance_metrics(table_from_rows(rows, SAFE_COLS), a_max=1.5, car_length=4.48)
    assert m["closing_samples"] == 2 and m["safe_share"] == pytest.approx(0.5)
    assert m["closing_samples_halted_leader"] == 0 and m["safe_share_moving_leader"] == pytest.approx(0.5)


PRESENCE_COLS = SAFE_COLS + ("arrived", "collided")


def test_a_car_that_arrived_is_nobodys_leader():
    # car 1 reached its goal during decision 1 (its row holds its pose on arrival) and left the
    # world; car 0 drove on to 2 m behind that pose: no leader, no sample
    rows = [(0, 0, 1, 0.0, 0.0, 0.0, 8.0, False, False), (0, 1, 1, 6.48, 0.0, 0.0, 8.0, True, False)]
    assert len(leader_samples(table_from_rows(rows, PRESENCE_COLS), car_length=4.48)["row"]) == 0


def test_a_wreck_stays_a_leader_at_speed_zero_until_the_episode_ends():
    # car 1 crashed on decision 1 at x = 24.48; car 0 drives on towards it at 6 m/s, then 4 m/s
    rows = [(0, 0, 1, 0.0, 0.0, 0.0, 6.0, False, False), (0, 1, 1, 24.48, 0.0, 0.0, 0.0, False, True),
            (0, 0, 2, 10.0, 0.0, 0.0, 6.0, False, False), (0, 0, 3, 12.0, 0.0, 0.0, 4.0, False, False)]
    table = table_from_rows(rows, PRESENCE_COLS)
    s = leader_samples(table, car_length=4.48)
    assert s["row"].tolist() == [0, 2, 3]  # the wreck itself (row 1) is no sample
    assert s["gap"].tolist() == pytest.approx([20.0, 10.0, 8.0])
    assert s["closing_speed"].tolist() == pytest.approx([6.0, 6.0, 4.0])
    # needs 12, 12, 5.33 m at a_max 1.5: the second sample is unsafe
    m = safety_distance_metrics(table, a_max=1.5, car_length=4.48)
    assert m["closing_samples"] == 3 and m["safe_share"] == pytest.approx(2 / 3)
    assert s["leader_halted"].tolist() == [True, True, True]  # a wreck from its crash row on
    assert (m["closing_samples_halted_leader"], m["unsafe_samples_halted_leader"]) == (3, 1)
    assert math.isnan(m["safe_share_moving_leader"])
    # with a moving pair in another episode (closing 6 m/s at a 13 m gap: safe): the share without
    # the wreck samples is that pair's alone
    moving = [(1, 0, 1, 0.0, 0.0, 0.0, 8.0, False, False), (1, 1, 1, 17.48, 0.0, 0.0, 2.0, False, False)]
    m = safety_distance_metrics(table_from_rows(rows + moving, PRESENCE_COLS), a_max=1.5, car_length=4.48)
    assert m["safe_share"] == pytest.approx(3 / 4) and m["safe_share_moving_leader"] == pytest.approx(1.0)
    # when collided cars are removed from the world (during the decision they crash on), never
    assert leader_samples(table, car_length=4.48, wrecks_stay=False)["row"].tolist() == []


def test_what_each_bit_says_includes_the_senders_speed():
    # bit 1 sent while driving at 6 m/s, bit 0 while stopped
    rows = [(0, 0, 0, 0.0, 0.0, np.nan, 0.0), (0, 0, 1, 0.0, 0.5, 0, 0.0), (0, 0, 2, 0.0, 0.5, 1, 6.0),
            (0, 0, 3, 0.0, 0.0, 1, 6.0), (0, 0, 4, 0.0, 0.0, 1, 6.0)]
    m = communication_metrics(table_from_rows(rows, COMM_COLS + ("speed",)))
    assert m["by_bit"]["1"]["share"] == pytest.approx(2 / 3)
    assert m["by_bit"]["1"]["speed_mean"] == pytest.approx(6.0)
    assert m["by_bit"]["0"]["speed_mean"] == pytest.approx(0.0)


def test_mutual_information_exact_values():
    assert mutual_information([0, 1, 0, 1], [5, 7, 5, 7]) == pytest.approx(1.0)
    assert mutual_information([0, 0, 1, 1], [5, 7, 5, 7]) == pytest.approx(0.0)


COMM_COLS = ("episode", "car", "decision", "heading", "acceleration", "bit_sent")


def test_communication_metrics_turn_signal():
    # the car sends 1 on the decision before it turns (heading changes next) and brakes next
    rows = [(0, 0, 0, 0.0, 0.0, np.nan), (0, 0, 1, 0.0, 1.5, 0), (0, 0, 2, 0.0, 1.5, 1),
            (0, 0, 3, 0.5, -1.5, 1), (0, 0, 4, 1.0, -1.5, 0), (0, 0, 5, 1.0, 1.5, 0)]
    m = communication_metrics(table_from_rows(rows, COMM_COLS))
    assert m["samples"] == 4  # decisions 1..4 have a next row
    # bits 0,1,1,0 -> next accel 1.5,-1.5,-1.5,1.5: fully determined
    assert m["speaker_consistency_bits"] == pytest.approx(1.0)
    # heading changes 0, 0.5, 0.5, 0 vs bits 0, 1, 1, 0
    assert m["pearson_heading_change_bit"] == pytest.approx(1.0)
    one = m["by_bit"]["1"]
    assert (one["share"], one["next_accel_mean"], one["abs_heading_change_mean"]) == pytest.approx((0.5, -1.5, 0.5))
    assert m["by_bit"]["0"]["next_accel_mean"] == pytest.approx(1.5)
    with pytest.raises(ValueError, match="communication=True"):
        communication_metrics(table_from_rows(rows[:2], COMM_COLS[:5]) | {"bit_sent": np.full(2, np.nan)})


def test_turn_signal_against_the_route_of_cars_that_arrived():
    from box2d_driving.metrics.communication import route_turns, turn_signal_metrics

    cols = COMM_COLS + ("arrived",)
    rows = []
    for car, headings, bits, arrived in ((0, (0.0, 0.0, 0.8, 1.57), (1, 1, 1), True),   # turns left, says 1
                                         (1, (0.0, 0.0, 0.0, 0.0), (0, 0, 0), True),    # straight, says 0
                                         (2, (0.0, -0.5, -1.0, -1.5), (1, 1, 1), True),  # turns right, says 1
                                         (3, (0.0, 0.7, 1.4, 1.5), (0, 0, 0), False)):   # crashed: route unknown
        rows.append((0, car, 0, headings[0], 0.0, np.nan, False))
        for t in (1, 2, 3):
            rows.append((0, car, t, headings[t], 0.0, bits[t - 1], arrived and t == 3))
    table = table_from_rows(rows, cols)
    turns = route_turns(table)
    assert turns[table["car"] == 0] == pytest.approx([1.57] * 4)
    assert np.isnan(turns[table["car"] == 3]).all()
    m = turn_signal_metrics(table)
    assert m["samples"] == 6  # decisions 1 and 2 of the three cars that arrived
    assert m["bit_one_share_by_movement"] == pytest.approx({"right": 1.0, "straight": 0.0, "left": 1.0})
    # the bit says "turning", not which way: it is determined by the movement, so the mutual
    # information is the bit's entropy H(1/3); the signed route correlation stays near zero
    h = -(1 / 3) * np.log2(1 / 3) - (2 / 3) * np.log2(2 / 3)
    assert m["movement_bit_mi_bits"] == pytest.approx(h)
    turn = np.array([1.57, 1.57, 0.0, 0.0, -1.5, -1.5])
    assert m["pearson_route_turn_bit"] == pytest.approx(np.corrcoef(turn, [1, 1, 0, 0, 1, 1])[0, 1])
    assert abs(m["pearson_route_turn_bit"]) < 0.05


def test_average_ranks_share_ties():
    assert average_ranks([3.0, 1.0, 2.0]).tolist() == [3.0, 1.0, 2.0]
    assert average_ranks([0.0, 0.0, 0.5, 0.5, 0.75]).tolist() == [1.5, 1.5, 3.5, 3.5, 5.0]


def test_rank_trend_exact_permutation_p_value():
    # four distinct levels, values rising: rho 1, and only the identity order of 4! reaches it
    t = rank_trend([0, 0.25, 0.5, 0.75], [0.1, 0.2, 0.3, 0.9])
    assert (t["n"], t["spearman"], t["p_rises"]) == (4, pytest.approx(1.0), pytest.approx(1 / 24))
    # falling: rho -1, every order reaches it
    t = rank_trend([0, 0.25, 0.5, 0.75], [4.0, 3.0, 2.0, 1.0])
    assert (t["spearman"], t["p_rises"]) == (pytest.approx(-1.0), pytest.approx(1.0))
    # two runs per level, ties in x: x ranks 1.5,1.5,3.5,3.5; y ranks 1,2,3,4 -> rho = 4/sqrt(4*5)
    t = rank_trend([0, 0, 1, 1], [1.0, 2.0, 3.0, 4.0])
    assert t["spearman"] == pytest.approx(4 / math.sqrt(20))
    # the orders with both low-noise values below both high-noise ones: 2! * 2! of 4! reach it
    assert t["p_rises"] == pytest.approx(4 / 24)
    # past max_exact the p-value comes from sampled orders (10 points rising: about 1/10! -> 0)
    t = rank_trend(np.arange(10.0), np.arange(10.0) ** 2, max_exact=8, permutations=2000)
    assert t["spearman"] == pytest.approx(1.0) and t["p_rises"] < 0.005
    assert math.isnan(rank_trend([0, 0, 0], [1.0, 2.0, 3.0])["spearman"])  # no spread in x
    with pytest.raises(ValueError, match="paired"):
        rank_trend([0, 1, 2], [1.0, 2.0])


CRASH_COLS = ("episode", "car", "decision", "heading", "in_junction", "collided", "collided_with",
              "collision_partner", "partner_halted")


def _crash(ep, car, t, heading, inside, with_, partner=-1, halted=False):
    from box2d_driving.metrics.rollouts import COLLIDED_WITH

    return (ep, car, t, heading, inside, True, COLLIDED_WITH.index(with_), partner, halted)


def test_collision_breakdown_classifies_each_collided_car_once():
    from box2d_driving.metrics.collisions import collision_breakdown, collision_classes

    d = math.radians
    rows = [
        (0, 0, 0, 0.0, False, False, 0, -1, False),       # a driving row: not a collision
        _crash(0, 0, 3, 0.0, True, "car", 1),             # 0 and 1 head-on: 180 degrees apart
        _crash(0, 1, 3, d(180), True, "car", 0),
        _crash(0, 2, 5, d(10), False, "car", 0, True),    # 2 hits wreck 0 two decisions later
        _crash(0, 3, 4, d(90), True, "car", 4),           # 3 and 4 cross at 80 degrees
        _crash(0, 4, 4, d(10), True, "car", 3),
        _crash(1, 0, 2, d(-170), False, "car", 1),        # episode 1: rear-end, 20 degrees apart
        _crash(1, 1, 2, d(170), False, "car", 0),
        _crash(1, 2, 6, 0.0, False, "edge"),
        _crash(1, 3, 7, 0.0, True, "pedestrian"),
    ]
    table = table_from_rows(rows, CRASH_COLS)
    c = collision_classes(table)
    assert c["row"].tolist() == list(range(1, 10))
    b = collision_breakdown(table)
    assert b["collided_cars"] == 9 and b["in_junction"] == 5
    assert b["by_kind"] == {
        "same_way": {"cars": 2, "in_junction": 0}, "crossing": {"cars": 2, "in_junction": 2},
        "oncoming": {"cars": 2, "in_junction": 2}, "wreck": {"cars": 1, "in_junction": 0},
        "edge": {"cars": 1, "in_junction": 0}, "pedestrian": {"cars": 1, "in_junction": 1}}
    # the thresholds are parameters: with a 90-degree "same way" the crossing pair counts as one
    assert collision_breakdown(table, same_way=math.pi / 2)["by_kind"]["same_way"]["cars"] == 4


def test_collision_breakdown_needs_the_partner_columns_and_the_partners_crash_row():
    from box2d_driving.metrics.collisions import collision_breakdown

    table = table_from_rows([_crash(0, 0, 3, 0.0, True, "car", 1)], CRASH_COLS)
    with pytest.raises(ValueError, match="car 0 hit moving car 1"):
        collision_breakdown(table)
    del table["partner_halted"]
    with pytest.raises(KeyError, match="evaluate the policy again"):
        collision_breakdown(table)


PILEUP_COLS = ("episode", "car", "decision", "x", "y", "speed", "heading", "in_junction", "collided",
               "collided_with", "collision_partner", "partner_halted")


def _pose(ep, car, t, x, speed, crash_with=None, partner=-1, halted=False):
    """A row on the x axis heading +x; with ``crash_with`` it is the car's crash row."""
    from box2d_driving.metrics.rollouts import COLLIDED_WITH

    if crash_with is None:
        return (ep, car, t, x, 0.0, speed, 0.0, True, False, 0, -1, False)
    return (ep, car, t, x, 0.0, speed, 0.0, True, True, COLLIDED_WITH.index(crash_with), partner, halted)


def test_wreck_collision_room_counts_pileups_that_braking_could_have_avoided():
    from box2d_driving.metrics.collisions import wreck_collision_room

    rows = [
        # episode 0: cars 0 and 1 crash into each other on decision 2 (wrecks at x = 0 and x = 4)
        _pose(0, 0, 2, 0.0, 0.0, "car", 1), _pose(0, 1, 2, 4.0, 0.0, "car", 0),
        # car 2 is 40 m from wreck 0 at 8 m/s then: gap 35.52 >= 64/3 = 21.33, room; hits it 3 later
        _pose(0, 2, 2, 40.0, 8.0), _pose(0, 2, 5, 4.5, 2.0, "car", 0, True),
        # car 3 is 12 m from wreck 1 at 8 m/s: gap 7.52 < 21.33, no room; hits it 1 decision later
        _pose(0, 3, 2, 16.0, 8.0), _pose(0, 3, 3, 8.5, 4.0, "car", 1, True),
        # episode 1: car 0 hits the edge; car 1 is 10 m behind at 3 m/s: gap 5.52 >= 3, room
        _pose(1, 0, 1, 0.0, 0.0, "edge"), _pose(1, 1, 1, 10.0, 3.0), _pose(1, 1, 4, 4.5, 1.0, "car", 0, True),
    ]
    table = table_from_rows(rows, PILEUP_COLS)
    r = wreck_collision_room(table, a_max=1.5, car_length=4.48)
    assert {k: r[k] for k in ("cars", "room_to_stop", "decisions_after_wreck_median",
                              "decisions_after_wreck_max")} == {
        "cars": 3, "room_to_stop": 2, "decisions_after_wreck_median": 3.0, "decisions_after_wreck_max": 3}
    # with room: car 2 (gap 35.52, 8 m/s, 3 decisions), car 1 of ep 1 (5.52, 3 m/s, 3); without: car 3
    assert r["with_room"] == pytest.approx({"cars": 2, "gap_median": 20.52, "speed_median": 5.5,
                                            "decisions_to_hit_median": 3.0})
    assert r["without_room"] == pytest.approx({"cars": 1, "gap_median": 7.52, "speed_median": 8.0,
                                               "decisions_to_hit_median": 1.0})
    # a gentler brake leaves less room: at a_max 0.5 car 2 needs 64 m and car 1 (ep 1) 9 m
    assert wreck_collision_room(table, a_max=0.5, car_length=4.48)["room_to_stop"] == 0
    none = wreck_collision_room(table_from_rows(rows[:2], PILEUP_COLS), 1.5, 4.48)
    assert none["cars"] == 0 and math.isnan(none["decisions_after_wreck_median"])
    assert none["with_room"]["cars"] == 0 and math.isnan(none["with_room"]["gap_median"])
    with pytest.raises(ValueError, match="no row on decision 2"):
        wreck_collision_room(table_from_rows(rows[:2] + rows[3:], PILEUP_COLS), 1.5, 4.48)


def test_unsafe_samples_are_broken_down_by_leader_closing_speed_and_outcome():
    from box2d_driving.metrics.right_of_way import unsafe_breakdown

    cols = SAFE_COLS + ("collided",)
    rows = [  # episode 0: car 0 closes at 6 m/s with a 10 m gap (needs 12 m): unsafe; it crashes 2 decisions later
        (0, 0, 1, 0.0, 0.0, 0.0, 8.0, 0), (0, 1, 1, 14.48, 0.0, 0.0, 2.0, 0), (0, 0, 3, 30.0, 0.0, 0.0, 0.0, 1),
        # episode 1: closing at 3 m/s with 2 m (needs 3 m): unsafe, never crashes
        (1, 0, 1, 0.0, 0.0, 0.0, 5.0, 0), (1, 1, 1, 6.48, 0.0, 0.0, 2.0, 0),
        # episode 2: closing at 1 m/s with 5 m: safe; episode 3: an opening gap, safe by definition
        (2, 0, 1, 0.0, 0.0, 0.0, 3.0, 0), (2, 1, 1, 9.48, 0.0, 0.0, 2.0, 0),
        (3, 0, 1, 0.0, 0.0, 0.0, 2.0, 0), (3, 1, 1, 9.48, 0.0, 0.0, 3.0, 0)]
    table = table_from_rows(rows, cols)
    s = leader_samples(table, car_length=4.48, wrecks_stay=False)
    b = unsafe_breakdown(table, s, a_max=1.5, car_length=4.48)
    assert b["unsafe_samples"] == 2
    assert b["by_leader"] == {"wreck": 0, "moving": 2}
    assert b["by_closing_speed"] == {"0-2": 0, "2-4": 1, "4-6": 0, ">=6": 1}
    assert b["by_outcome"] == {"collides_within_3": 1, "collides_later": 0, "no_collision": 1}
    assert b["safe_share_every_leader_sample"] == pytest.approx(2 / 4)  # 4 samples with a leader, 2 unsafe
    # centre distances 14.48 and 6.48 m against 12 and 3 m: both safe then; 9.48 against 0.33 safe
    assert b["safe_share_centre_distance"] == pytest.approx(1.0)
