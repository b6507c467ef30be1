"""The map file format: reading, writing and refusing map files, and the shipped Helsinki maps as
files (their OpenStreetMap import is tested in ``test_maps.py``)."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest

from box2d_driving.maps import MapError, load_map

ROOT = Path(__file__).resolve().parent.parent
SHIPPED = sorted((ROOT / "assets" / "maps").glob("*.json"))


# ---- the JSON format -------------------------------------------------------------------------------
def test_json_round_trip_and_no_silent_overwrite(junction, tmp_path):
    out = junction.save(tmp_path / "m.json")
    again = load_map(out)
    assert again.to_dict() == junction.to_dict()
    with pytest.raises(MapError, match="exists"):
        junction.save(out)
    junction.save(out, overwrite=True)


@pytest.mark.parametrize("breakage, message", [
    (lambda d: d.pop("format"), "not a box2d-driving-map"),
    (lambda d: d.update(version=99), "unsupported map version"),
    (lambda d: d["lanes"][0].update(arm=42), r"lanes\[0\].arm"),
    (lambda d: d["lanes"][0].update(width=-1), r"lanes\[0\].width must be"),
    (lambda d: d["lanes"][0].update(width="wide"), r"lanes\[0\].width must be"),
    (lambda d: d["lanes"][1]["centreline"][0].__setitem__(0, float("nan")),
     r"lanes\[1\].centreline: coordinates must be finite"),
    (lambda d: d["edges"][2][0].__setitem__(1, 1e6), r"edges\[2\]: coordinates must lie within"),
    (lambda d: d["lanes"].__setitem__(0, [1, 2]), r"lanes\[0\]: expected an object"),
    (lambda d: d["arms"][0].update(cut=float("nan")), r"arms\[0\].cut must be true or false"),
    (lambda d: d["stop_lines"][0].update(s=float("inf")), r"stop_lines\[0\].s must be"),
    (lambda d: d.update(drivable="everywhere"), "drivable"),
    (lambda d: d["connectors"][0].update(movement="fly"), "movement must be one of"),
    (lambda d: d["connectors"][0].update(from_lane=d["connectors"][0]["to_lane"]), "inbound lane to an outbound"),
    (lambda d: d["arms"][0].update(centreline=[[0, 0]]), r"arms\[0\].centreline"),
    (lambda d: d.update(phases=[[7]]), "phases"),
    (lambda d: d["spawn_regions"][0].update(s_range=[5, 1]), "s_range"),
])
def test_malformed_maps_are_refused_with_the_field_named(junction, tmp_path, breakage, message):
    data = json.loads(json.dumps(junction.to_dict()))
    breakage(data)
    path = tmp_path / "bad.json"
    path.write_text(json.dumps(data))
    with pytest.raises(MapError, match=message):
        load_map(path)


def test_json_nested_too_deeply_is_a_map_error(tmp_path):
    path = tmp_path / "deep.json"
    path.write_text("[" * 100_000 + "]" * 100_000)
    with pytest.raises(MapError, match="nested too deeply"):
        load_map(path)


def test_not_json_is_refused(tmp_path):
    path = tmp_path / "x.json"
    path.write_text("{not json")
    with pytest.raises(MapError, match="not valid JSON"):
        load_map(path)


# ---- the shipped maps --------------------------------------------------------------------------
def test_shipped_maps_load_and_carry_attribution():
    assert 3 <= len(SHIPPED) <= 5
    for path in SHIPPED:
        m = load_map(path)
        assert m.source["licence"] == "ODbL-1.0" and "OpenStreetMap" in m.source["attribution"]
        assert len(m.arms) >= 3 and m.signals and m.connectors
        assert {c.movement for c in m.connectors} >= {"straight", "left", "right"}
        assert any(m.connectors[k].movement != c.movement for c in m.connectors for k in c.conflicts)


def test_a_built_package_carries_the_shipped_maps(tmp_path):
    """A wheel holds what ``build_py`` builds: the maps must be in it, and the package must find
    them there when no checkout's assets/ is next to it."""
    import subprocess
    import sys

    lib = tmp_path / "lib"
    subprocess.run([sys.executable, "setup.py", "-q", "build_py", "--build-lib", str(lib)], cwd=ROOT,
                   check=True, capture_output=True)
    packaged = sorted((lib / "box2d_driving" / "maps" / "junctions").glob("*.json"))
    assert [p.name for p in packaged] == [p.name for p in SHIPPED]
    assert all(p.read_bytes() == q.read_bytes() for p, q in zip(packaged, SHIPPED))
    probe = ("import box2d_driving, box2d_driving.maps.shipped as s; "
             "env = box2d_driving.make('real-junction-v0'); env.reset(seed=0); "
             "print(box2d_driving.__file__); print(s.SHIPPED_DIR); print(len(s.shipped_maps()))")
    out = subprocess.run([sys.executable, "-c", probe], cwd=tmp_path, env={**os.environ, "PYTHONPATH": str(lib)},
                         check=True, capture_output=True, text=True).stdout.split("\n")
    assert out[0].startswith(str(lib)) and out[1] == str(lib / "box2d_driving" / "maps" / "junctions")
    assert int(out[2]) == len(SHIPPED)
