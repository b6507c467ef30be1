"""The nuScenes map-expansion importer on a small hand-built file in that format."""

from __future__ import annotations

import copy
import json
import math
from collections import Counter

import numpy as np
import pytest

import box2d_driving
from box2d_driving.cli import main as cli
from box2d_driving.maps import MapError, load_map
from box2d_driving.maps import geometry as geo
from box2d_driving.maps.nuscenes import import_patch
from box2d_driving.maps.nuscenes_format import arcline_points
from tests.nuscenes_fixtures import CENTRE, four_way_nuscenes


def test_arcline_paths_follow_their_shape():
    straight = arcline_points({"start_pose": [0, 0, 0], "shape": "SSS", "radius": 5, "segment_length": [10, 0, 0]})
    np.testing.assert_allclose(straight[-1], [10, 0], atol=1e-9)
    left = arcline_points({"start_pose": [0, 0, 0], "shape": "LSS", "radius": 5,
                           "segment_length": [math.pi * 2.5, 3, 0]})
    np.testing.assert_allclose(left[-1], [5, 8], atol=1e-9)  # quarter circle to (5, 5), then 3 m north
    right = arcline_points({"start_pose": [1, 1, math.pi / 2], "shape": "RSR", "radius": 2,
                            "segment_length": [math.pi, 0, 0]})
    np.testing.assert_allclose(right[-1], [3, 3], atol=1e-9)  # heading north, quarter right turn
    assert geo.min_radius(left[: len(left) // 2]) == pytest.approx(5.0, rel=1e-3)


@pytest.fixture(scope="module")
def nus():
    return import_patch(four_way_nuscenes(), centre=tuple(CENTRE + 1.0))


def test_lanes_connectors_and_movements(nus):
    m = nus
    assert len(m.arms) == 4 and all(len(a.lanes_in) == 1 and len(a.lanes_out) == 1 for a in m.arms)
    assert Counter(c.movement for c in m.connectors) == {"straight": 4, "left": 4, "right": 4}
    for c in m.connectors:
        np.testing.assert_allclose(c.path[0], m.lanes[c.from_lane].centreline[-1], atol=1e-6)
        np.testing.assert_allclose(c.path[-1], m.lanes[c.to_lane].centreline[0], atol=1e-6)
        expected = {"straight": math.inf, "left": 9.75, "right": 6.25}[c.movement]
        assert c.min_radius == pytest.approx(expected, rel=1e-2)
    for lane in m.lanes:  # widths from polygon area / length
        assert lane.width == pytest.approx(3.5, abs=0.05)
    left = [c for c in m.connectors if c.movement == "left"]
    oncoming_straight = [c for c in m.connectors if c.movement == "straight"
                         and m.lanes[c.from_lane].arm != m.lanes[left[0].from_lane].arm]
    assert any(s.id in left[0].conflicts for s in oncoming_straight)


def test_signals_stop_lines_crosswalks_and_area(nus):
    m = nus
    assert sorted(s.arm for s in m.stop_lines) == [0, 1, 2, 3]
    assert all(s.s == pytest.approx(12.25) for s in m.stop_lines)
    assert all(h.source_id.startswith("tl-") and not h.inferred for h in m.signals)
    by_arm = {h.arm: h.group for h in m.signals}
    assert by_arm[0] == by_arm[2] != by_arm[1] == by_arm[3]  # opposite approaches share a phase
    assert len(m.crosswalks) == 4 and all(c.s == pytest.approx(10.0) for c in m.crosswalks)
    assert geo.points_in_polygon(np.zeros((1, 2)), m.junction_area)[0]
    for s in m.stop_lines:  # the junction area reaches the stop lines
        ring = np.vstack([m.junction_area, m.junction_area[:1]])
        assert geo.distance_to_polylines(s.segment.mean(axis=0)[None], [ring])[0] < 0.3
    assert m.source["road_segment"] == "junction-0001" and "nuScenes" in m.source["attribution"]



def test_approaches_without_stop_lines_get_one_at_the_lane_ends():
    """A file without ``stop_line`` records still imports: each approach's stop line lies across
    its inbound lane ends, a note says so, and the map names its own road segment."""
    data = four_way_nuscenes()
    data["stop_line"] = []
    m = import_patch(data, centre=tuple(CENTRE + 1.0))
    assert sorted(s.arm for s in m.stop_lines) == [0, 1, 2, 3]
    for line in m.stop_lines:
        end = m.lanes[m.arms[line.arm].lanes_in[0]].centreline[-1]
        assert np.linalg.norm(line.segment.mean(axis=0) - end) < 1e-6
        assert f"approach {line.arm}: no stop line in the data; one at the lane ends" in m.notes
    assert m.source["road_segment"] == "junction-0001" and len(m.signals) == 4

def test_round_trip_and_driving_on_it(nus, tmp_path):
    path = nus.save(tmp_path / "nus.json")
    assert load_map(path).to_dict() == nus.to_dict()
    env = box2d_driving.make("real-junction-v0", map=str(path), num_cars=1, light_period_range=(100.0, 101.0))
    outcomes = Counter()
    for seed in range(40):
        obs, infos = env.reset(seed=seed)
        while env.agents:
            obs, _, _, _, infos = env.step({a: 12 for a in env.agents})
        outcomes[(infos["car_0"]["arrived"], infos["car_0"]["collided_with"])] += 1
    assert outcomes == Counter({(True, None): 40})


def test_bad_files_name_the_problem(tmp_path):
    data = four_way_nuscenes()
    broken = copy.deepcopy(data)
    del broken["lane"]
    with pytest.raises(MapError, match="no 'lane' layer"):
        import_patch(broken)
    with pytest.raises(MapError, match="no intersection road_segment 'nope'"):
        import_patch(data, centre="nope")
    two = copy.deepcopy(data)
    two["road_segment"].append(dict(two["road_segment"][0], token="junction-0002"))
    with pytest.raises(MapError, match="2 intersections"):
        import_patch(two)
    orphan = copy.deepcopy(data)
    orphan["polygon"][0]["exterior_node_tokens"].append("ghost")
    with pytest.raises(MapError, match="ghost"):
        import_patch(orphan)
    with pytest.raises(MapError, match="does not exist"):
        import_patch(tmp_path / "none.json")



@pytest.mark.parametrize("breakage", [
    lambda d: d["lane"][0].pop("token"),
    lambda d: d["node"][0].__setitem__("x", "abc"),
    lambda d: d.__setitem__("connectivity", []),
    lambda d: next(iter(d["arcline_path_3"].values()))[0].__setitem__("shape", "QQQ"),
    lambda d: d["traffic_light"][0].__setitem__("pose", {"tx": "a", "ty": 1.0}),
    lambda d: d["road_segment"][0].pop("polygon_token"),
    lambda d: d["stop_line"][0].pop("polygon_token"),
])
def test_malformed_records_are_one_map_error_naming_the_file(tmp_path, breakage):
    data = four_way_nuscenes()
    breakage(data)
    path = tmp_path / "city.json"
    path.write_text(json.dumps(data))
    with pytest.raises(MapError, match=r"city\.json: cannot import the intersection at \(501, 301\): malformed data"):
        import_patch(path, centre=tuple(CENTRE + 1.0))


@pytest.mark.parametrize("centre", [("a", "b"), (1.0, 2.0, 3.0), (math.nan, 1.0), 5])
def test_a_centre_that_is_not_a_point_is_refused(centre):
    with pytest.raises(MapError, match="centre must be \\(x, y\\)"):
        import_patch(four_way_nuscenes(), centre=centre)

def test_import_nuscenes_command(tmp_path, capsys):
    src = tmp_path / "map.json"
    src.write_text(json.dumps(four_way_nuscenes()))
    out = tmp_path / "junction.json"
    assert cli(["import-nuscenes", str(src), "--segment", "junction-0001", "--out", str(out)]) == 0
    assert "4 arms" in capsys.readouterr().out and load_map(out).connectors
    assert cli(["import-nuscenes", str(src), "--centre", "500,300", "--out", str(out)]) == 2
    assert "exists" in capsys.readouterr().err
