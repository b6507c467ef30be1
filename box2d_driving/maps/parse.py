"""Reading a road-map file: the JSON, the format's checks, and :class:`~box2d_driving.maps.roadmap.RoadMap`
from it. Every check names the element and the file, so a malformed map gives one
:class:`~box2d_driving.maps.roadmap.MapError` saying what is wrong and where.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np

from box2d_driving.maps.roadmap import (FORMAT, MOVEMENTS, VERSION, Arm, Connector, Crosswalk, Lane, MapError,
                                        RoadMap, SignalHead, SpawnRegion, StopLine)

# Map coordinates are metres from the junction centre. The world runs in float32, whose spacing at
# 1e4 m is about 1 mm; at 1e6 m it is 6 cm, enough to change who touches whom.
MAX_COORD = 1e4


def _pts(value: Any, what: str, min_points: int = 2) -> np.ndarray:
    if isinstance(value, (str, bytes, dict)) or not isinstance(value, list):
        raise MapError(f"{what}: expected a list of [x, y] points, got {type(value).__name__}")
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError, OverflowError) as exc:
        raise MapError(f"{what}: expected a list of [x, y] points ({exc})") from None
    if arr.ndim != 2 or arr.shape[1] != 2 or len(arr) < min_points:
        raise MapError(f"{what}: expected at least {min_points} [x, y] points, got shape {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise MapError(f"{what}: coordinates must be finite")
    if np.abs(arr).max() > MAX_COORD:
        raise MapError(f"{what}: coordinates must lie within ±{MAX_COORD:g} m of the junction centre "
                       f"(got {np.abs(arr).max():.6g}); re-centre the map")
    return arr


def _num(value: Any, what: str, low: float = -MAX_COORD, high: float = MAX_COORD,
         integer: bool = False) -> float:
    """A finite number in ``[low, high]`` (an integer if asked) from a map file."""
    ok = isinstance(value, int) if integer else isinstance(value, (int, float))
    if isinstance(value, bool) or not ok or not math.isfinite(value) or not low <= value <= high:
        kind = "an integer" if integer else "a finite number"
        raise MapError(f"{what} must be {kind} in [{low:g}, {high:g}], got {value!r}")
    return int(value) if integer else float(value)


def _flag(value: Any, what: str) -> bool:
    if not isinstance(value, bool):
        raise MapError(f"{what} must be true or false, got {value!r}")
    return value


def _obj(value: Any, what: str) -> dict:
    if not isinstance(value, dict):
        raise MapError(f"{what}: expected an object, got {type(value).__name__}")
    return value


def read_json(path: str | Path, what: str) -> Any:
    """Parsed JSON of ``path``; :class:`MapError` if it is missing or not JSON."""
    path = Path(path)
    if not path.is_file():
        raise MapError(f"{what} {path} does not exist")
    try:
        return json.loads(path.read_text())
    except (json.JSONDecodeError, UnicodeDecodeError) as exc:
        raise MapError(f"{path} is not valid JSON: {exc}") from None
    except RecursionError:
        raise MapError(f"{path}: JSON nested too deeply to be a map") from None


def load_map(path: str | Path) -> RoadMap:
    """Read and validate a map JSON file (:class:`MapError` naming the problem if malformed)."""
    return parse_map(read_json(path, "map file"), str(path))


def parse_map(data: Any, where: str) -> RoadMap:
    """A :class:`RoadMap` from parsed JSON ``data`` (``where`` names it in errors)."""
    try:
        return _parse_checked(data, where)
    except MapError:
        raise
    except (TypeError, ValueError, AttributeError, KeyError, IndexError, OverflowError, RecursionError) as exc:
        # a shape the element checks below do not foresee: still one MapError naming the file
        raise MapError(f"{where}: malformed map ({type(exc).__name__}: {exc})") from None


def _need(obj: dict, key: str, where: str) -> Any:
    if not isinstance(obj, dict) or key not in obj:
        raise MapError(f"{where}: missing {key!r}")
    return obj[key]


def _ids(values: Any, n: int, what: str) -> list[int]:
    if not isinstance(values, list) or not all(isinstance(v, int) and 0 <= v < n for v in values):
        raise MapError(f"{what}: expected a list of ids in [0, {n}), got {values!r}")
    return list(values)


def _parse_checked(data: Any, where: str) -> RoadMap:
    if not isinstance(data, dict) or data.get("format") != FORMAT:
        raise MapError(f"{where}: not a {FORMAT} file (missing or wrong 'format')")
    if data.get("version") != VERSION:
        raise MapError(f"{where}: unsupported map version {data.get('version')!r} (this package reads {VERSION})")
    raw_lanes = _need(data, "lanes", where)
    raw_arms = _need(data, "arms", where)
    if not isinstance(raw_lanes, list) or not isinstance(raw_arms, list) or not raw_arms:
        raise MapError(f"{where}: 'arms' and 'lanes' must be non-empty lists")
    n_arms, n_lanes = len(raw_arms), len(raw_lanes)
    arms = [_arm(i, a, n_lanes, f"{where}: arms[{i}]") for i, a in enumerate(raw_arms)]
    lanes = [_lane(i, la, n_arms, f"{where}: lanes[{i}]") for i, la in enumerate(raw_lanes)]
    raw_conn = data.get("connectors", [])
    connectors = [_connector(i, c, lanes, len(raw_conn), f"{where}: connectors[{i}]") for i, c in enumerate(raw_conn)]
    stop_lines = [StopLine(arm=_ids([_need(s, "arm", where)], n_arms, f"{where}: stop_lines[{i}].arm")[0],
                           s=_num(_need(s, "s", where), f"{where}: stop_lines[{i}].s"),
                           segment=_pts(_need(s, "segment", where), f"{where}: stop_lines[{i}].segment"))
                  for i, s in enumerate(data.get("stop_lines", []))]
    signals = [_signal(i, h, n_arms, f"{where}: signals[{i}]") for i, h in enumerate(data.get("signals", []))]
    phases = data.get("phases", [])
    if signals:
        groups = {h.group for h in signals}
        if (not isinstance(phases, list) or not phases
                or not all(isinstance(p, list) and all(g in groups for g in p) for p in phases)):
            raise MapError(f"{where}: 'phases' must list, per phase, the signal groups that are green")
    crosswalks = [Crosswalk(arm=_ids([_need(c, "arm", where)], n_arms, f"{where}: crosswalks[{i}].arm")[0],
                            s=_num(_need(c, "s", where), f"{where}: crosswalks[{i}].s"),
                            polygon=_pts(_need(c, "polygon", where), f"{where}: crosswalks[{i}].polygon", 3),
                            kind=str(c.get("kind", "unknown")), source_id=c.get("source_id"))
                  for i, c in enumerate(data.get("crosswalks", []))]
    drivable = [_pts(p, f"{where}: drivable[{i}]", 3) for i, p in enumerate(_need(data, "drivable", where))]
    edges = [_pts(p, f"{where}: edges[{i}]") for i, p in enumerate(_need(data, "edges", where))]
    spawns = [_spawn_region(s, n_lanes, f"{where}: spawn_regions[{i}]")
              for i, s in enumerate(data.get("spawn_regions", []))]
    source = data.get("source", {})
    if not isinstance(source, dict):
        raise MapError(f"{where}: 'source' must be an object")
    area = _pts(_need(data, "junction_area", where), f"{where}: junction_area", 3)
    size = _num(data.get("size_m", 0.0), f"{where}: size_m", 0.0)
    return RoadMap(name=str(data.get("name", "")), source=source, size_m=size,
                   arms=arms, lanes=lanes, connectors=connectors, stop_lines=stop_lines, signals=signals,
                   phases=phases if signals else [], crosswalks=crosswalks, drivable=drivable, edges=edges,
                   spawn_regions=spawns, junction_area=area, notes=[str(n) for n in data.get("notes", [])])


def _arm(i: int, a: Any, n_lanes: int, w: str) -> Arm:
    """Arm ``i`` of the file (``w`` names it in errors)."""
    a = _obj(a, w)
    return Arm(id=i, name=str(a.get("name", "")), highway=str(a.get("highway", "")),
               centreline=_pts(_need(a, "centreline", w), f"{w}.centreline"),
               mouth=_num(_need(a, "mouth", w), f"{w}.mouth"),
               lanes_in=_ids(_need(a, "lanes_in", w), n_lanes, f"{w}.lanes_in"),
               lanes_out=_ids(_need(a, "lanes_out", w), n_lanes, f"{w}.lanes_out"),
               cut=_flag(a.get("cut", False), f"{w}.cut"), source_ids=list(a.get("source_ids", [])))


def _lane(i: int, la: Any, n_arms: int, w: str) -> Lane:
    """Lane ``i`` of the file: on an existing arm, inbound or outbound, of positive width."""
    la = _obj(la, w)
    direction = _need(la, "direction", w)
    if direction not in ("in", "out"):
        raise MapError(f"{w}.direction must be 'in' or 'out', got {direction!r}")
    arm = _need(la, "arm", w)
    if not isinstance(arm, int) or not 0 <= arm < n_arms:
        raise MapError(f"{w}.arm: no arm {arm!r}")
    width = _num(_need(la, "width", w), f"{w}.width", 0.0, 100.0)
    if not width > 0:
        raise MapError(f"{w}.width must be positive, got {width}")
    return Lane(id=i, arm=arm, direction=direction,
                index=int(_num(_need(la, "index", w), f"{w}.index", 0, 1000, integer=True)),
                width=width, centreline=_pts(_need(la, "centreline", w), f"{w}.centreline"))


def _connector(i: int, c: Any, lanes: list[Lane], n_connectors: int, w: str) -> Connector:
    """Connector ``i``: from an inbound lane to an outbound one, a known movement, conflicts that
    name other connectors."""
    c = _obj(c, w)
    fl, tl = _need(c, "from_lane", w), _need(c, "to_lane", w)
    _ids([fl, tl], len(lanes), f"{w} lanes")
    if lanes[fl].direction != "in" or lanes[tl].direction != "out":
        raise MapError(f"{w}: must lead from an inbound lane to an outbound lane")
    movement = _need(c, "movement", w)
    if movement not in MOVEMENTS:
        raise MapError(f"{w}.movement must be one of {MOVEMENTS}, got {movement!r}")
    radius = c.get("min_radius")
    return Connector(id=i, from_lane=fl, to_lane=tl, movement=movement, path=_pts(_need(c, "path", w), f"{w}.path"),
                     conflicts=_ids(c.get("conflicts", []), n_connectors, f"{w}.conflicts"),
                     min_radius=float("inf") if radius is None else _num(radius, f"{w}.min_radius", 0.0, 1e300))


def _signal(i: int, h: Any, n_arms: int, w: str) -> SignalHead:
    """Signal head ``i``: on an existing arm, in a non-negative signal group."""
    group = _need(h, "group", w)
    if not isinstance(group, int) or group < 0:
        raise MapError(f"{w}.group must be a non-negative integer")
    return SignalHead(id=i, arm=_ids([_need(h, "arm", w)], n_arms, f"{w}.arm")[0], group=group,
                      position=_pts([_need(h, "position", w)], f"{w}.position", 1)[0],
                      source_id=h.get("source_id"), inferred=_flag(h.get("inferred", False), f"{w}.inferred"))


def _spawn_region(s: Any, n_lanes: int, w: str) -> SpawnRegion:
    """A spawn region: on an existing lane, ``s_range`` as ``[low, high]`` with 0 <= low <= high (m)."""
    lane = _ids([_need(s, "lane", w)], n_lanes, f"{w}.lane")[0]
    bounds = _need(s, "s_range", w)
    if not isinstance(bounds, list) or len(bounds) != 2:
        raise MapError(f"{w}.s_range must be [low, high], got {bounds!r}")
    lo, hi = (_num(v, f"{w}.s_range") for v in bounds)
    if not 0 <= lo <= hi:
        raise MapError(f"{w}.s_range must be 0 <= low <= high, got {[lo, hi]}")
    return SpawnRegion(lane=lane, s_range=(lo, hi))
