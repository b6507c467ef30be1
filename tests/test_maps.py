"""The OSM importer on hand-built files and on the shipped Helsinki extract, and build_map on
hand-described arms (the map file format: ``test_map_files.py``)."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from box2d_driving.cli import main as cli
from box2d_driving.maps import ImportConfig, MapError, RoadMap, load_map
from box2d_driving.maps import geometry as geo
from box2d_driving.maps.osm import import_junction, lane_counts, turn_lanes
from tests.helpers import assert_nested_close
from tests.osm_fixtures import divided, four_way

ROOT = Path(__file__).resolve().parent.parent
PBF = ROOT / "assets" / "maps" / "source" / "Helsinki.osm.pbf"


def arm(m: RoadMap, name: str):
    return next(a for a in m.arms if a.name == name)


# ---- geometry ---------------------------------------------------------------------------------
def test_geometry_helpers_match_analytic_answers():
    line = np.array([[0.0, 0.0], [10.0, 0.0]])
    np.testing.assert_allclose(geo.offset(line, 2.0), [[0, -2], [10, -2]])  # right of +x is -y
    t = np.linspace(0, math.pi / 2, 200)
    arc = 7.0 * np.stack([np.cos(t), np.sin(t)], axis=1)
    assert geo.min_radius(arc) == pytest.approx(7.0, rel=1e-3)
    assert geo.min_radius(line) == math.inf
    curve = geo.bezier(np.zeros(2), np.array([1.0, 2.0]), np.array([3.0, 2.0]), np.array([4.0, 0.0]))
    np.testing.assert_allclose([curve[0], curve[-1]], [[0, 0], [4, 0]])
    square = np.array([[0, 0], [2, 0], [2, 2], [0, 2]], float)
    assert geo.points_in_polygon(np.array([[1, 1], [3, 1]], float), square).tolist() == [True, False]
    assert geo.polylines_cross(np.array([[0, -1], [0, 1]], float), np.array([[-1, 0], [1, 0]], float))
    assert not geo.polylines_cross(np.array([[0, 1], [0, 2]], float), np.array([[-1, 0], [1, 0]], float))
    np.testing.assert_allclose(geo.point_at(line, 2.5), [2.5, 0])


# ---- tags ------------------------------------------------------------------------------------------
@pytest.mark.parametrize("tags, outward_forward, expected", [
    ({"highway": "primary", "lanes:forward": "1", "lanes:backward": "2"}, True, (2, 1)),
    ({"highway": "primary", "lanes:forward": "1", "lanes:backward": "2"}, False, (1, 2)),
    ({"highway": "primary", "lanes": "3", "lanes:forward": "1"}, True, (2, 1)),
    ({"highway": "primary", "lanes": "2", "oneway": "yes"}, True, (0, 2)),
    ({"highway": "primary", "lanes": "2", "oneway": "yes"}, False, (2, 0)),
    ({"highway": "secondary", "lanes": "1", "oneway": "-1"}, True, (1, 0)),
    ({"highway": "residential"}, True, (1, 1)),
    ({"highway": "primary", "oneway": "yes"}, False, (2, 0)),  # one-way primary default: 2 lanes
    ({"highway": "residential", "lanes": "many"}, True, (1, 1)),
])
def test_lane_counts_from_tags(tags, outward_forward, expected):
    notes: list[str] = []
    assert lane_counts(tags, outward_forward, ImportConfig(), notes) == expected
    if tags.get("lanes") == "many":
        assert any("not a lane count" in n for n in notes)


def test_turn_lanes_parse_per_direction():
    tags = {"turn:lanes": "left;through|through;right", "turn:lanes:backward": "left|right"}
    assert turn_lanes(tags, inbound_forward=True) == [{"left", "straight"}, {"straight", "right"}]
    assert turn_lanes(tags, inbound_forward=False) == [{"left"}, {"right"}]
    assert turn_lanes({}, True) is None


# ---- the importer on a hand-built junction -------------------------------------------------------
def test_arms_lanes_and_chained_ways(junction):
    m = junction
    assert sorted(a.name for a in m.arms) == ["East", "North", "South", "West"]
    counts = {a.name: (len(a.lanes_in), len(a.lanes_out)) for a in m.arms}
    assert counts == {"East": (1, 1), "West": (2, 0), "North": (1, 1), "South": (1, 0)}
    east = arm(m, "East")
    assert east.source_ids == [10, 11]  # chained across the way split at 20 m
    assert geo.cumulative_length(east.centreline)[-1] == pytest.approx(50.0, abs=0.1)  # size_m / 2
    assert not east.cut
    assert any("no lane tags" in n and "13" in n for n in m.notes)
    # arms are ordered counter-clockwise from the west
    angles = [math.atan2(*a.centreline[-1][::-1]) for a in m.arms]
    assert angles == sorted(angles)


def test_lanes_sit_on_the_right_and_point_the_right_way(junction):
    for lane in junction.lanes:
        a = junction.arms[lane.arm]
        out_dir = a.centreline[-1] / np.linalg.norm(a.centreline[-1])
        travel = lane.centreline[-1] - lane.centreline[0]
        assert np.sign(travel @ out_dir) == (1 if lane.direction == "out" else -1)
        # right-hand traffic: a lane of a two-way arm is right of the axis in its own direction
        if a.lanes_in and a.lanes_out:
            mid = lane.centreline[len(lane.centreline) // 2]
            d = travel / np.linalg.norm(travel)
            assert (mid @ np.array([d[1], -d[0]])) > 0


def test_connectors_follow_turn_lanes_stay_on_the_road_and_list_conflicts(junction):
    m, cfg = junction, ImportConfig()
    west = arm(m, "West")
    by_lane = {lane: {c.movement for c in m.connectors_from(lane)} for lane in west.lanes_in}
    assert by_lane[west.lanes_in[0]] == {"left", "straight"}  # "left;through"
    assert by_lane[west.lanes_in[1]] == {"straight"}  # "through;right", but south takes no traffic
    south = arm(m, "South")
    assert not any(m.lanes[c.to_lane].arm == south.id for c in m.connectors)
    for c in m.connectors:
        assert c.min_radius >= cfg.min_turn_radius
        assert np.allclose(c.path[0], m.lanes[c.from_lane].centreline[-1])
        assert np.allclose(c.path[-1], m.lanes[c.to_lane].centreline[0])
        inside = np.zeros(len(c.path), bool)
        for poly in m.drivable:
            inside |= geo.points_in_polygon(c.path, poly)
        assert inside.all()
        for other in c.conflicts:  # symmetric, never from the same lane
            assert c.id in m.connectors[other].conflicts
            assert m.connectors[other].from_lane != c.from_lane
    # west -> east straight crosses the north -> south-going... north's left turn (to east) merges
    straight_we = next(c for c in m.connectors if c.movement == "straight"
                       and m.lanes[c.from_lane].arm == west.id)
    north_left = next(c for c in m.connectors if m.lanes[c.from_lane].arm == arm(m, "North").id
                      and c.movement == "left")
    assert north_left.id in straight_we.conflicts


def test_signals_crosswalks_stop_lines(junction):
    m = junction
    north, east, west, south = (arm(m, n) for n in ("North", "East", "West", "South"))
    heads = {h.arm: h for h in m.signals}
    assert set(heads) == {a.id for a in m.arms if a.lanes_in}
    assert heads[north.id].source_id == 6 and not heads[north.id].inferred
    assert heads[west.id].inferred and any("inferred" in n for n in m.notes)
    # two phases: the busiest approach (west) with the opposite one, crossing approaches apart
    assert heads[west.id].group == heads[east.id].group != heads[north.id].group == heads[south.id].group
    assert m.phases == [[0], [1]]
    kinds = {(m.arms[c.arm].name, c.kind) for c in m.crosswalks}
    assert ("North", "unknown") in kinds  # highway=crossing without crossing=*
    assert ("East", "uncontrolled") in kinds  # the footway crossing way
    for c in m.crosswalks:
        line = m.stop_line(c.arm)
        if line is not None:  # the stop line is behind the crosswalk
            assert line.s >= c.s + ImportConfig().crosswalk_width / 2
        assert c.s - ImportConfig().crosswalk_width / 2 >= m.arms[c.arm].mouth - 1e-9
    for region in m.spawn_regions:
        assert 0 <= region.s_range[0] < region.s_range[1]


def test_extract_edge_is_refused_or_trimmed(tmp_path):
    path = four_way(tmp_path / "cut.osm", east_cut=True)
    with pytest.raises(MapError, match="extract's edge"):
        import_junction(path, 1)
    m = import_junction(path, 1, ImportConfig(min_arm_length=15.0))
    east = arm(m, "East")
    assert east.cut and geo.cumulative_length(east.centreline)[-1] == pytest.approx(20.0, abs=0.1)
    assert any("extract's edge" in n for n in m.notes)


def test_dual_carriageway_nodes_merge_into_one_junction(tmp_path):
    m = import_junction(divided(tmp_path / "dual.osm"), 2)
    assert len(m.arms) == 4
    assert m.source["junction_nodes"] == [1, 2]
    avenue = [a for a in m.arms if a.name == "Avenue"]
    assert len(avenue) == 2 and all(len(a.lanes_in) == 1 and len(a.lanes_out) == 1 for a in avenue)
    assert any("dual carriageway" in n for n in m.notes)
    assert m.signals and all(h.inferred for h in m.signals)  # the junction node itself is signalled
    for lane in m.lanes:  # the inbound carriageway stays on its own side of the median
        a = m.arms[lane.arm]
        if a.name == "Avenue":
            assert np.linalg.norm(lane.centreline[0] - lane.centreline[-1]) > 20
    # the median is kerbed: edges on both sides, not drivable, and no connector crosses it
    for a in avenue:
        lane_in, lane_out = m.lanes[a.lanes_in[0]].centreline, m.lanes[a.lanes_out[0]].centreline
        mid = 0.5 * (lane_in[len(lane_in) // 2] + lane_out[len(lane_out) // 2])  # between the carriageways
        assert not any(geo.points_in_polygon(mid[None], p)[0] for p in m.drivable)
        assert geo.distance_to_polylines(mid[None], m.edges)[0] < 4.0
    assert {c.movement for c in m.connectors} == {"straight", "left", "right"}
    for c in m.connectors:
        inside = np.zeros(len(c.path), bool)
        for poly in m.drivable:
            inside |= geo.points_in_polygon(c.path, poly)
        assert inside.all()


def test_bad_requests_name_the_problem(tmp_path):
    path = four_way(tmp_path / "four.osm")
    with pytest.raises(MapError, match="not a junction"):
        import_junction(path, 2)
    with pytest.raises(MapError, match="not on a road"):
        import_junction(path, 12345)
    with pytest.raises(MapError, match="does not exist"):
        import_junction(tmp_path / "missing.osm.pbf", 1)
    with pytest.raises(MapError, match="no road junction within 50 m"):
        import_junction(path, (61.0, 25.0))
    near = import_junction(path, (60.00005, 25.00005))  # ~6 m from node 1
    assert near.source["node"] == 1
    with pytest.raises(MapError, match="min_arm_length"):
        ImportConfig(min_arm_length=80.0)


def test_osm_nodes_with_bad_coordinates_are_one_map_error(tmp_path):
    import re

    text = four_way(tmp_path / "a.osm").read_text()
    for node, lat in (("2", "nan"), ("6", "nan"), ("6", "95.0"), ("2", "95.0")):
        bad = tmp_path / f"bad_{node}_{lat}.osm"
        bad.write_text(re.sub(rf'(<node id="{node}" version="1" )lat="[^"]*"', rf'\1lat="{lat}"', text))
        with pytest.raises(MapError, match=re.escape(str(bad))):
            import_junction(bad, 1)


# ---- the shipped map and the command --------------------------------------------------------------
def test_shipped_map_is_reproduced_by_the_importer():
    """Geometry within 1e-6 m (numpy and libosmium releases move the last bits of computed
    floats); any real change to the importer moves a map by far more, and fails here."""
    path = ROOT / "assets" / "maps" / "helsinki_25345669.json"
    imported, shipped = import_junction(PBF, 25345669).to_dict(), load_map(path).to_dict()
    assert_nested_close(imported, shipped, atol=1e-6)
    moved = json.loads(json.dumps(shipped))  # a change of 1e-5 m in one vertex is caught
    moved["lanes"][0]["centreline"][0][0] += 1e-5
    with pytest.raises(AssertionError, match=r"lanes\[0\]\.centreline\[0\]\[0\]"):
        assert_nested_close(imported, moved, atol=1e-6)


def test_import_osm_command(tmp_path, capsys):
    src = four_way(tmp_path / "four.osm")
    out = tmp_path / "map.json"
    assert cli(["import-osm", str(src), "--node", "1", "--out", str(out)]) == 0
    assert "4 arms" in capsys.readouterr().out and load_map(out).arms
    assert cli(["import-osm", str(src), "--node", "1", "--out", str(out)]) == 2
    assert "exists" in capsys.readouterr().err
    assert cli(["import-osm", str(src), "--node", "2", "--out", str(tmp_path / "x.json")]) == 2
    assert "not a junction" in capsys.readouterr().err
    assert cli(["import-osm", str(src), "--out", str(tmp_path / "y.json")]) == 2
    left = tmp_path / "left.json"
    assert cli(["import-osm", str(src), "--node", "1", "--drive-on", "left", "--out", str(left)]) == 0
    assert load_map(left).source["drive_on"] == "left"
    # an existing picture is not replaced silently either, and the map is not written
    png = tmp_path / "mine.png"
    png.write_bytes(b"my picture")
    fresh = tmp_path / "fresh.json"
    assert cli(["import-osm", str(src), "--node", "1", "--out", str(fresh), "--png", str(png)]) == 2
    assert "--png" in capsys.readouterr().err and png.read_bytes() == b"my picture" and not fresh.exists()


def test_junction_area_reaches_the_stop_lines(junction):
    m = junction
    assert geo.points_in_polygon(np.zeros((1, 2)), m.junction_area)[0]
    for line in m.stop_lines:
        axis = m.arms[line.arm].centreline
        inward, outward = geo.point_at(axis, line.s - 0.5), geo.point_at(axis, line.s + 0.5)
        assert geo.points_in_polygon(np.array([inward, outward]), m.junction_area).tolist() == [True, False]


def test_left_hand_traffic_is_the_mirror_image(tmp_path):
    """drive_on="left": lanes keep left, the short turn is the left turn, the turn across
    oncoming traffic is the right turn, turn:lanes are read left to right as in reality."""
    osm = four_way(tmp_path / "four.osm")
    right = import_junction(osm, 1)
    left = import_junction(osm, 1, ImportConfig(drive_on="left"))
    assert left.source["drive_on"] == "left" and "drive_on" not in right.source
    assert sorted(a.name for a in left.arms) == sorted(a.name for a in right.arms)
    for m, side in ((right, -1.0), (left, 1.0)):  # side of the axis, looking along the lane
        for lane in m.lanes:
            a = m.arms[lane.arm]
            mid = lane.centreline[len(lane.centreline) // 2]
            d = lane.centreline[-1] - lane.centreline[0]
            d = d / np.linalg.norm(d)
            if a.lanes_in and a.lanes_out:
                assert np.sign(mid @ np.array([-d[1], d[0]])) == side
        # lane 0 is the leftmost in its direction
        for a in m.arms:
            for ids in (a.lanes_in, a.lanes_out):
                lanes = [m.lanes[i] for i in ids]
                assert [la.index for la in lanes] == list(range(len(lanes)))
                if len(lanes) == 2:
                    d = lanes[0].centreline[-1] - lanes[0].centreline[0]
                    middle = [lane.centreline[len(lane.centreline) // 2] for lane in lanes[:2]]
                    gap = middle[0] - middle[1]
                    assert gap @ np.array([-d[1], d[0]]) > 0
        for c in m.connectors:  # a left turn turns counter-clockwise in both
            h = np.diff(c.path, axis=0)
            turn = math.remainder(math.atan2(h[-1, 1], h[-1, 0]) - math.atan2(h[0, 1], h[0, 0]), 2 * math.pi)
            assert c.movement == "straight" or (turn > 0) == (c.movement == "left")
    # the turn towards the kerb is the short one (mean path length over the map's turns)
    def length(m, movement):
        return np.mean([geo.cumulative_length(c.path)[-1] for c in m.connectors if c.movement == movement])
    assert length(right, "right") < length(right, "left")
    assert length(left, "left") < length(left, "right")
    # turn:lanes "left;through|through;right" on West: its leftmost lane turns left in both
    for m in (right, left):
        west = arm(m, "West")
        assert {c.movement for c in m.connectors_from(west.lanes_in[0])} >= {"left"}
        assert "right" not in {c.movement for c in m.connectors_from(west.lanes_in[0])}
    # a left-hand map drives: cars spawn and follow it
    import box2d_driving

    path = left.save(tmp_path / "left.json")
    env = box2d_driving.make("real-junction-v0", map=str(path), num_cars=4)
    env.reset(seed=0)
    for _ in range(5):
        env.step({a: 12 for a in env.agents})
    with pytest.raises(MapError, match="drive_on"):
        ImportConfig(drive_on="middle")


def test_importing_osm_without_osmium_says_which_extra_to_install(tmp_path, monkeypatch, capsys):
    import sys

    from box2d_driving.cli import main as cli

    monkeypatch.setitem(sys.modules, "osmium", None)  # as if the [osm] extra were not installed
    src = tmp_path / "x.osm"
    src.write_text("<osm></osm>")
    assert cli(["import-osm", str(src), "--node", "1", "--out", str(tmp_path / "m.json")]) == 2
    err = capsys.readouterr().err
    assert ".[osm]" in err and "Traceback" not in err and not (tmp_path / "m.json").exists()


def test_build_map_lays_out_a_hand_described_junction_and_leaves_its_arms_as_given():
    """The builder an importer of one's own calls: a T junction from three straight arms (one lane
    each way) gets every turn it allows, signals on request, and the caller's arms unchanged."""
    from box2d_driving.maps.arm_spec import ArmSpec
    from box2d_driving.maps.build import build_map

    def road(heading_deg: float) -> np.ndarray:  # every 2.5 m: not the builder's own sampling
        d = np.array([math.cos(math.radians(heading_deg)), math.sin(math.radians(heading_deg))])
        return np.arange(0.0, 62.5, 2.5)[:, None] * d

    arms = [ArmSpec(centreline=road(h), lanes_in=1, lanes_out=1, lane_width=3.5, name=n)
            for h, n in ((0, "east"), (90, "north"), (180, "west"))]
    given = [a.centreline.copy() for a in arms]
    m = build_map(arms, ImportConfig(size_m=120), "t", {"kind": "hand-drawn"}, signalled=True)
    assert len(m.lanes) == 6 and len(m.signals) == 3 and len(m.stop_lines) == 3
    turns = {(m.arms[m.lanes[c.from_lane].arm].name, c.movement) for c in m.connectors}
    assert turns == {("east", "straight"), ("east", "right"), ("west", "straight"), ("west", "left"),
                     ("north", "left"), ("north", "right")}
    assert all(np.array_equal(a.centreline, g) for a, g in zip(arms, given))


@pytest.mark.parametrize("field,value,message", [
    ("lane_width", -3.5, "lane_width must be a positive number"),
    ("lane_width", float("nan"), "lane_width must be a positive number"),
    ("median", -1.0, "median must be a non-negative number"),
    ("lanes_in", -1, "lanes_in must be a non-negative integer"),
    ("lanes_out", 1.5, "lanes_out must be a non-negative integer"),
    ("centreline", np.zeros((1, 2)), "two or more finite"),
    ("centreline", np.full((20, 2), np.nan), "two or more finite"),
    ("centreline", np.zeros((20, 3)), "two or more finite"),
    ("centreline", "north", "centreline must be"),
    ("turn_lanes", [{"sideways"}], "turn_lanes must be"),
])
@pytest.mark.parametrize("drive_on", ["right", "left"])
def test_build_map_names_the_arm_and_field_it_cannot_use(field, value, message, drive_on):
    from box2d_driving.maps.arm_spec import ArmSpec
    from box2d_driving.maps.build import build_map

    arms = [ArmSpec(centreline=np.arange(0.0, 60.0)[:, None] * [math.cos(h), math.sin(h)], lanes_in=1,
                    lanes_out=1, lane_width=3.5, name=n) for h, n in ((0.0, "east"), (math.pi / 2, "north"),
                                                                      (math.pi, "west"))]
    setattr(arms[1], field, value)
    with pytest.raises(MapError, match=f"arm 'north': .*{message}"):
        build_map(arms, ImportConfig(drive_on=drive_on), "t", {})
    arms[1] = ArmSpec(centreline=arms[0].centreline * [0.0, 1.0], lanes_in=0, lanes_out=0, lane_width=3.5)
    with pytest.raises(MapError, match="arm 1: it has no lanes"):
        build_map(arms, ImportConfig(drive_on=drive_on), "t", {})


def test_osm_corner_cases_import_or_fail_naming_the_cause(tmp_path):
    """Negative ids (valid OSM, written by editors) import; a position that is no position, a
    junction nothing can cross and a file with a node twice are each said."""
    from tests.osm_fixtures import write_osm

    plus = {"highway": "primary"}
    nodes = {-1: (0, 0, {}), -2: (60, 0, {}), -3: (-60, 0, {}), -4: (0, 60, {}), -5: (0, -60, {})}
    ways = {-10: ([-1, -2], plus), -11: ([-3, -1], plus), -12: ([-1, -4], plus), -13: ([-1, -5], plus)}
    negative = write_osm(tmp_path / "negative.osm", nodes, ways)
    assert len(import_junction(negative, -1).arms) == 4
    with pytest.raises(MapError, match=r"junction position \(nan, nan\) is not a latitude"):
        import_junction(negative, (float("nan"), float("nan")))
    inbound = write_osm(tmp_path / "inbound.osm", {1: (0, 0, {}), 2: (60, 0, {}), 3: (-60, 0, {}), 4: (0, 60, {})},
                        {10: ([2, 1], {**plus, "oneway": "yes"}), 11: ([3, 1], {**plus, "oneway": "yes"}),
                         12: ([4, 1], {**plus, "oneway": "yes"})})
    with pytest.raises(MapError, match="junction at node 1 has no way through"):
        import_junction(inbound, 1)
    text = negative.read_text().splitlines()
    twice = [line for line in text if line.startswith('<node id="-2"')]
    doubled = tmp_path / "doubled.osm"
    doubled.write_text("\n".join(text[:text.index(twice[0]) + 1] + twice + text[text.index(twice[0]) + 1:]))
    assert any("node id(s) appear twice (-2)" in n for n in import_junction(doubled, -1).notes)
