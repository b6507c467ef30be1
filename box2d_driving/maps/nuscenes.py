"""Import a junction from a nuScenes map-expansion JSON (for users who have the dataset).

``import_patch("boston-seaport.json", centre=(x, y))`` (or a ``road_segment`` token) returns the
same :class:`RoadMap` the OSM importer does, with nuScenes' own geometry:

* the junction: the ``road_segment`` with ``is_intersection`` containing (or nearest) ``centre``;
  everything is shifted so that its centroid is the origin and cut to a ``size_m`` square;
* lanes and connectors: ``lane`` and ``lane_connector`` records, their centre lines discretised from
  ``arcline_path_3`` (straight and constant-radius pieces), linked by ``connectivity``; a lane
  feeding a kept connector is inbound, one fed by it outbound; lane width = lane polygon area /
  centre-line length;
* arms: lanes grouped by the bearing of their junction end from the centre;
* stop lines (``stop_line``, as the long axis of the polygon), signals (``traffic_light`` poses,
  to the nearest approach), crosswalks (``ped_crossing``), drivable polygons and road edges
  (``drivable_area`` rings clipped to the square); the junction area is the hull of the
  intersection polygon and the stop lines.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Optional, Union

import numpy as np

from box2d_driving.maps import geometry as geo
from box2d_driving.maps.build import signal_groups
from box2d_driving.maps.config import ImportConfig
from box2d_driving.maps.connectors import classify_turn, mark_conflicts
from box2d_driving.maps.nuscenes_format import Layers, pick_intersection
from box2d_driving.maps.parse import read_json
from box2d_driving.maps.roadmap import (Arm, Connector, Crosswalk, Lane, MapError, RoadMap, SignalHead,
                                        SpawnRegion, StopLine)
from box2d_driving.road.geometry import Path as TrackPath

LICENCE = {"licence": "nuScenes terms of use (CC BY-NC-SA 4.0)", "attribution": "nuScenes map expansion (Motional)"}


def import_patch(source: Union[str, Path, dict], centre: Union[tuple[float, float], str, None] = None,
                 cfg: Optional[ImportConfig] = None, name: Optional[str] = None) -> RoadMap:
    """The junction of a nuScenes map-expansion file (or its parsed dict) at ``centre`` (x, y in
    the map's metres, or an intersection ``road_segment`` token; None if there is exactly one).
    :class:`MapError` names what is missing or malformed."""
    where = "nuScenes map" if isinstance(source, dict) else str(source)
    if centre is not None and not isinstance(centre, str):
        try:
            point = np.asarray(centre, dtype=float)
        except (TypeError, ValueError):
            point = np.empty(0)
        if point.shape != (2,) or not np.isfinite(point).all():
            raise MapError(f"{where}: centre must be (x, y) in the map's metres or a road_segment token, "
                           f"got {centre!r}")
    try:
        return _import_patch(source, where, centre, cfg or ImportConfig(), name)
    except MapError:
        raise
    except (IndexError, KeyError, ValueError, TypeError, AttributeError, ZeroDivisionError,
            FloatingPointError) as exc:
        # records the checks along the way do not foresee: still one MapError naming the file
        raise MapError(f"{where}: cannot import {_junction_asked(centre)}: malformed data "
                       f"({type(exc).__name__}: {exc})") from None


def _junction_asked(centre: Union[tuple[float, float], str, None]) -> str:
    """The junction ``centre`` asks for, in words."""
    if centre is None:
        return "its intersection"
    if isinstance(centre, str):
        return f"intersection {centre!r}"
    try:
        return "the intersection at ({:g}, {:g})".format(*(float(v) for v in centre))
    except (TypeError, ValueError, IndexError):
        return f"the intersection at {centre!r}"


def _import_patch(source: Union[str, Path, dict], where: str, centre: Union[tuple[float, float], str, None],
                  cfg: ImportConfig, name: Optional[str]) -> RoadMap:
    data = source if isinstance(source, dict) else read_json(source, "nuScenes map file")
    layers = Layers(data, where)
    segment = pick_intersection(layers, centre)
    junction_abs = layers.polygon_ring(segment["polygon_token"])
    frame = _Frame(origin=junction_abs.mean(axis=0), half=cfg.size_m / 2)
    junction = frame.local(junction_abs)
    notes: list[str] = []

    connector_paths = _junction_connectors(layers, frame, junction)
    lane_lines, lane_widths = _car_lanes(layers, frame, cfg)
    links = _links(layers, connector_paths, lane_lines)
    if not links:
        raise MapError(f"{where}: no lane connector of intersection {segment['token']!r} links two lanes")
    inbound = sorted({i for i, _, _ in links})
    outbound = sorted({o for _, _, o in links})
    if set(inbound) & set(outbound):
        raise MapError(f"{where}: lanes {sorted(set(inbound) & set(outbound))} both enter and leave the junction")
    approaches = _group_approaches(lane_lines, inbound, outbound, frame, lane_widths, cfg)
    if len(approaches.arms) < 3:
        raise MapError(f"{where}: intersection {segment['token']!r} has {len(approaches.arms)} approaches; "
                       "need at least 3")
    connectors = _connect(links, connector_paths, approaches.lane_id, cfg)
    stop_lines = _stop_lines(layers, frame, approaches, notes)
    signals = _signals(layers, frame, approaches, stop_lines, notes)
    crosswalks = _crosswalks(layers, frame, approaches)
    drivable, edges = _surface(layers, frame, junction)
    if not edges:
        raise MapError(f"{where}: no drivable_area boundary near intersection {segment['token']!r}")
    area = geo.convex_hull(np.vstack([junction] + [x.segment for x in stop_lines]))
    described = {"kind": "nuscenes-map-expansion", "file": None if isinstance(source, dict) else Path(source).name,
                 "road_segment": segment["token"], "centre_xy": [float(v) for v in frame.origin], **LICENCE}
    return RoadMap(name=name or f"nuscenes_{segment['token'][:8]}", source=described, size_m=cfg.size_m,
                   arms=approaches.arms, lanes=approaches.lanes, connectors=connectors, stop_lines=stop_lines,
                   signals=signals, phases=[[g] for g in sorted({h.group for h in signals})], crosswalks=crosswalks,
                   drivable=drivable, edges=edges, spawn_regions=_spawn_regions(approaches.lanes, stop_lines, cfg),
                   junction_area=area, notes=list(dict.fromkeys(notes)))


@dataclass
class _Frame:
    """The map's local frame: metres from the junction polygon's centroid ``origin`` (in the
    file's coordinates), cut to the square of half-side ``half``."""

    origin: np.ndarray
    half: float

    def local(self, points: np.ndarray) -> np.ndarray:
        return np.asarray(points, float) - self.origin

    def inside(self, points: np.ndarray) -> np.ndarray:
        """Per local point: within the square."""
        return np.max(np.abs(points), axis=-1) <= self.half


@dataclass
class _Approaches:
    """The junction's arms (lanes grouped by the bearing of their junction end), their lanes,
    each arm's outward direction (rad) and each nuScenes lane token's lane id."""

    arms: list[Arm]
    lanes: list[Lane]
    angles: list[float]
    lane_id: dict[str, int]

    def nearest(self, p: np.ndarray, need_in: bool) -> Optional[int]:
        """The arm whose direction is nearest the bearing of local point ``p`` (within 45
        degrees; with ``need_in``, only arms with inbound lanes), or None."""
        b = math.atan2(p[1], p[0])
        cands = [(abs(math.remainder(b - self.angles[k], 2 * math.pi)), k) for k in range(len(self.arms))
                 if self.arms[k].lanes_in or not need_in]
        best = min(cands, default=None)
        return None if best is None or best[0] > math.radians(45) else best[1]

    def along(self, k: int, p: np.ndarray) -> float:
        """Distance of local point ``p`` along arm ``k``'s outward direction (m)."""
        out = self.arms[k].centreline[-1]
        return float(p @ out / np.linalg.norm(out))


def _junction_connectors(layers: Layers, frame: _Frame, junction: np.ndarray) -> dict[str, np.ndarray]:
    """The ``lane_connector`` centre lines (local) whose midpoint lies in the junction polygon."""
    paths = {}
    for rec in layers.data["lane_connector"]:
        line = layers.centreline(rec["token"])
        if line is not None and geo.points_in_polygon(frame.local(line)[len(line) // 2:len(line) // 2 + 1],
                                                      junction)[0]:
            paths[rec["token"]] = frame.local(line)
    return paths


def _car_lanes(layers: Layers, frame: _Frame, cfg: ImportConfig) -> tuple[dict[str, np.ndarray], dict[str, float]]:
    """Centre lines (local) of the car lanes reaching into the square, and their widths where the
    lane polygon gives one (its area over the centre line's length, clipped to
    ``cfg.lane_width_range``)."""
    lines, widths = {}, {}
    for rec in layers.data["lane"]:
        if rec.get("lane_type", "CAR") != "CAR":
            continue
        line = layers.centreline(rec["token"])
        if line is None:
            continue
        line = frame.local(line)
        if frame.inside(line).sum() < 2:
            continue
        lines[rec["token"]] = line
        poly = layers.polygon_ring(rec["polygon_token"]) if rec.get("polygon_token") in layers.polygon else None
        length = float(geo.cumulative_length(line)[-1])
        if poly is not None and length > 0:
            x, y = poly[:, 0], poly[:, 1]
            area = 0.5 * abs(np.dot(x, np.roll(y, 1)) - np.dot(y, np.roll(x, 1)))
            widths[rec["token"]] = float(np.clip(area / length, *cfg.lane_width_range))
    return lines, widths


def _links(layers: Layers, connector_paths: dict[str, np.ndarray],
           lane_lines: dict[str, np.ndarray]) -> list[tuple[str, str, str]]:
    """(inbound lane, connector, outbound lane) tokens that ``connectivity`` joins through the
    junction's connectors."""
    connectivity = layers.data["connectivity"]
    links = []
    for ct in connector_paths:
        ins = [t for t in connectivity.get(ct, {}).get("incoming", []) if t in lane_lines]
        outs = [t for t in connectivity.get(ct, {}).get("outgoing", []) if t in lane_lines]
        links += [(i, ct, o) for i in ins for o in outs]
    return links


def _group_approaches(lane_lines: dict[str, np.ndarray], inbound: list[str], outbound: list[str], frame: _Frame,
                      lane_widths: dict[str, float], cfg: ImportConfig) -> _Approaches:
    """Each lane clipped to the square (the piece touching the junction) and the lanes grouped into
    arms: neighbours by the bearing of their junction end closer than 35 degrees share an arm."""
    lines = {}
    for t in inbound + outbound:
        idx = np.flatnonzero(frame.inside(lane_lines[t]))
        lines[t] = lane_lines[t][idx[0]:idx[-1] + 1]
    junction_end = {t: (lines[t][-1] if t in inbound else lines[t][0]) for t in lines}
    bearing = {t: math.atan2(p[1], p[0]) for t, p in junction_end.items()}

    def close(a: str, b: str) -> bool:
        return abs(math.remainder(bearing[a] - bearing[b], 2 * math.pi)) < math.radians(35)

    arms_of: list[list[str]] = []
    for t in sorted(lines, key=lambda t: bearing[t]):
        if arms_of and close(t, arms_of[-1][0]):
            arms_of[-1].append(t)
        else:
            arms_of.append([t])
    if len(arms_of) > 1 and close(arms_of[0][0], arms_of[-1][0]):  # the group across +-180 degrees
        arms_of[0] = arms_of.pop() + arms_of[0]

    arms: list[Arm] = []
    lanes: list[Lane] = []
    lane_id: dict[Any, int] = {}
    angles: list[float] = []
    for k, tokens in enumerate(arms_of):
        a = math.atan2(np.mean([math.sin(bearing[t]) for t in tokens]), np.mean([math.cos(bearing[t]) for t in tokens]))
        out_dir = np.array([math.cos(a), math.sin(a)])
        right = np.array([out_dir[1], -out_dir[0]])
        reach = max(float(np.max(lines[t] @ out_dir)) for t in tokens)
        mouth = float(min(junction_end[t] @ out_dir for t in tokens))
        axis = np.array([[0.0, 0.0], out_dir * max(reach, mouth + 1)])
        arm = Arm(id=k, name=f"approach {k}", highway="", centreline=axis, mouth=max(mouth, 0.0),
                  lanes_in=[], lanes_out=[], source_ids=sorted(tokens))
        for direction, ids, sign in (("in", arm.lanes_in, -1.0), ("out", arm.lanes_out, 1.0)):
            members = [t for t in tokens if (t in inbound) == (direction == "in")]
            members.sort(key=lambda t: sign * float(junction_end[t] @ right))  # leftmost first
            for index, t in enumerate(members):
                lane_id[t] = len(lanes)
                lanes.append(Lane(id=len(lanes), arm=k, direction=direction, index=index,
                                  width=lane_widths.get(t, cfg.lane_width), centreline=lines[t]))
                ids.append(lane_id[t])
        arms.append(arm)
        angles.append(a)
    return _Approaches(arms=arms, lanes=lanes, angles=angles, lane_id=lane_id)


def _connect(links: list[tuple[str, str, str]], connector_paths: dict[str, np.ndarray], lane_id: dict[str, int],
             cfg: ImportConfig) -> list[Connector]:
    """A connector per link (U-turns left out), its movement from the turn between its ends, with
    conflicts marked."""
    connectors: list[Connector] = []
    for i, ct, o in links:
        path = connector_paths[ct]
        d0, d1 = path[1] - path[0], path[-1] - path[-2]
        turn = math.remainder(math.atan2(d1[1], d1[0]) - math.atan2(d0[1], d0[0]), 2 * math.pi)
        movement = classify_turn(turn, cfg)
        if movement == "uturn":
            continue
        connectors.append(Connector(id=len(connectors), from_lane=lane_id[i], to_lane=lane_id[o], movement=movement,
                                    path=path, min_radius=geo.min_radius(path)))
    mark_conflicts(connectors)
    return connectors


def _stop_lines(layers: Layers, frame: _Frame, approaches: _Approaches, notes: list[str]) -> list[StopLine]:
    """Each approach's stop line: the ``stop_line`` polygon nearest the junction on it, as its long
    axis; where the data has none, one across the lane ends (with a note)."""
    stop_lines: list[StopLine] = []
    for rec in layers.data.get("stop_line", []):
        poly = frame.local(layers.polygon_ring(rec["polygon_token"]))
        c = poly.mean(axis=0)
        k = approaches.nearest(c, True) if frame.inside(c) else None
        if k is None:
            continue
        s = approaches.along(k, c)
        prev = next((x for x in stop_lines if x.arm == k), None)
        if prev is None or s < prev.s:
            stop_lines = [x for x in stop_lines if x.arm != k] + [StopLine(arm=k, s=s, segment=geo.long_axis(poly))]
    for arm in approaches.arms:
        if arm.lanes_in and not any(x.arm == arm.id for x in stop_lines):
            ends = np.array([approaches.lanes[t].centreline[-1] for t in arm.lanes_in])
            across = ends[[0, -1]] if len(ends) > 1 else np.array([ends[0] - 1e-3, ends[0] + 1e-3])
            stop_lines.append(StopLine(arm=arm.id, s=arm.mouth, segment=across))
            notes.append(f"approach {arm.id}: no stop line in the data; one at the lane ends")
    stop_lines.sort(key=lambda x: x.arm)
    return stop_lines


def _signals(layers: Layers, frame: _Frame, approaches: _Approaches, stop_lines: list[StopLine],
             notes: list[str]) -> list[SignalHead]:
    """When any ``traffic_light`` lies on an approach, a signal head at every stop line (those no
    light was found for inferred, with a note) in a two-phase plan; else none."""
    found: dict[int, Any] = {}
    for rec in layers.data.get("traffic_light", []):
        pose = rec.get("pose", {})
        p = frame.local(np.array([pose.get("tx", np.nan), pose.get("ty", np.nan)], float))
        if not np.all(np.isfinite(p)) and rec.get("line_token") in layers.line:
            p = frame.local(layers.ring(layers.line[rec["line_token"]]["node_tokens"]).mean(axis=0))
        if np.all(np.isfinite(p)) and frame.inside(p):
            k = approaches.nearest(p, True)
            if k is not None and k not in found:
                found[k] = rec["token"]
    signals: list[SignalHead] = []
    if not found:
        return signals
    arms = approaches.arms
    groups = signal_groups(approaches.angles, [len(a.lanes_in) for a in arms], [len(a.lanes_out) for a in arms])
    for line in stop_lines:
        signals.append(SignalHead(id=len(signals), arm=line.arm, group=groups[line.arm],
                                  position=line.segment.mean(axis=0), source_id=found.get(line.arm),
                                  inferred=line.arm not in found))
        if line.arm not in found:
            notes.append(f"approach {line.arm}: no traffic light found; signal head inferred")
    return signals


def _crosswalks(layers: Layers, frame: _Frame, approaches: _Approaches) -> list[Crosswalk]:
    """The ``ped_crossing`` polygons in the square, each on its nearest arm."""
    crosswalks = []
    for rec in layers.data.get("ped_crossing", []):
        poly = frame.local(layers.polygon_ring(rec["polygon_token"]))
        c = poly.mean(axis=0)
        k = approaches.nearest(c, False) if frame.inside(c) else None
        if k is not None:
            crosswalks.append(Crosswalk(arm=k, s=approaches.along(k, c), polygon=poly, kind="ped_crossing",
                                        source_id=rec["token"]))
    return crosswalks


def _surface(layers: Layers, frame: _Frame, junction: np.ndarray) -> tuple[list[np.ndarray], list[np.ndarray]]:
    """Drivable polygons (the junction polygon, then the ``drivable_area`` rings clipped to the
    square) and road edges (those rings' boundaries and holes, clipped)."""
    drivable = [junction]
    edges: list[np.ndarray] = []
    for rec in layers.data.get("drivable_area", []):
        for token in rec.get("polygon_tokens", []):
            ring = frame.local(layers.polygon_ring(token))
            clipped = geo.clip_polygon_to_square(ring, frame.half)
            if len(clipped):
                drivable.append(clipped)
            for r in [ring] + [frame.local(h) for h in layers.polygon_holes(token)]:
                edges += geo.clip_ring_to_square(r, frame.half)
    return drivable, edges


def _spawn_regions(lanes: list[Lane], stop_lines: list[StopLine], cfg: ImportConfig) -> list[SpawnRegion]:
    """On each inbound lane: from its outer end to ``cfg.spawn_gap`` before its stop line."""
    spawns = []
    for lane in lanes:
        if lane.direction == "in":
            track = TrackPath.from_points(lane.centreline)
            line = next(x for x in stop_lines if x.arm == lane.arm)
            hi = track.project(line.segment.mean(axis=0)) - cfg.spawn_gap
            if hi > 0:
                spawns.append(SpawnRegion(lane=lane.id, s_range=(0.0, float(hi))))
    return spawns
