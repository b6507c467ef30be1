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
from pathlib import Path
from typing import Any, Optional, Union

import numpy as np

from box2d_driving.maps import geometry as geo
from box2d_driving.maps.build import mark_conflicts, signal_groups
from box2d_driving.maps.config import ImportConfig
from box2d_driving.maps.parse import read_json
from box2d_driving.maps.roadmap import (Arm, Connector, Crosswalk, Lane, MapError, RoadMap, SignalHead,
                                        SpawnRegion, StopLine)
from box2d_driving.road.geometry import Path as TrackPath

LICENCE = {"licence": "nuScenes terms of use (CC BY-NC-SA 4.0)", "attribution": "nuScenes map expansion (Motional)"}
_SIGN = {"L": 1.0, "S": 0.0, "R": -1.0}


def arcline_points(path: dict, step: float = 0.5) -> np.ndarray:
    """Points along one ``arcline_path_3``: from ``start_pose`` (x, y, yaw), each of the three
    pieces of ``shape`` (L: left arc, S: straight, R: right arc, radius ``radius``) for its
    ``segment_length``."""
    x, y, yaw = (float(v) for v in path["start_pose"][:3])
    r = float(path.get("radius", 0.0))
    pts = [(x, y)]
    for kind, length in zip(path["shape"], path["segment_length"]):
        length = float(length)
        if length <= 0:
            continue
        sign = _SIGN[kind]
        n = max(int(math.ceil(length / step)), 1)
        for k in range(1, n + 1):
            s = length * k / n
            if sign == 0 or r <= 0:
                px, py = x + s * math.cos(yaw), y + s * math.sin(yaw)
            else:
                turn = sign * s / r
                px = x + sign * r * (math.sin(yaw + turn) - math.sin(yaw))
                py = y - sign * r * (math.cos(yaw + turn) - math.cos(yaw))
            pts.append((px, py))
        if sign == 0 or r <= 0:
            x, y = x + length * math.cos(yaw), y + length * math.sin(yaw)
        else:
            turn = sign * length / r
            x += sign * r * (math.sin(yaw + turn) - math.sin(yaw))
            y -= sign * r * (math.cos(yaw + turn) - math.cos(yaw))
            yaw += turn
    return geo.dedupe(np.array(pts))


class _Layers:
    """Token lookups over the map-expansion layers."""

    def __init__(self, data: dict, where: str) -> None:
        for key in ("node", "polygon", "lane", "lane_connector", "road_segment", "arcline_path_3", "connectivity"):
            if key not in data:
                raise MapError(f"{where}: not a nuScenes map-expansion file (no {key!r} layer)")
        self.data = data
        self.node = {n["token"]: (float(n["x"]), float(n["y"])) for n in data["node"]}
        self.polygon = {p["token"]: p for p in data["polygon"]}
        self.line = {ln["token"]: ln for ln in data.get("line", [])}
        self.where = where

    def ring(self, tokens: list[str]) -> np.ndarray:
        try:
            return np.array([self.node[t] for t in tokens])
        except KeyError as exc:
            raise MapError(f"{self.where}: node {exc} is referenced but not defined") from None

    def polygon_ring(self, token: str) -> np.ndarray:
        if token not in self.polygon:
            raise MapError(f"{self.where}: polygon {token!r} is referenced but not defined")
        return self.ring(self.polygon[token]["exterior_node_tokens"])

    def polygon_holes(self, token: str) -> list[np.ndarray]:
        return [self.ring(h["node_tokens"]) for h in self.polygon[token].get("holes", [])]

    def centreline(self, token: str) -> Optional[np.ndarray]:
        paths = self.data["arcline_path_3"].get(token)
        if not paths:
            return None
        return geo.dedupe(np.vstack([arcline_points(p) for p in paths]))


def import_patch(source: Union[str, Path, dict], centre: Union[tuple[float, float], str, None] = None,
                 cfg: Optional[ImportConfig] = None, name: Optional[str] = None) -> RoadMap:
    """The junction of a nuScenes map-expansion file (or its parsed dict) at ``centre`` (x, y in
    the map's metres, or an intersection ``road_segment`` token; None if there is exactly one).
    :class:`MapError` names what is missing or malformed."""
    cfg = cfg or ImportConfig()
    where = "nuScenes map" if isinstance(source, dict) else str(source)
    data = source if isinstance(source, dict) else read_json(source, "nuScenes map file")
    L = _Layers(data, where)
    seg = _pick_intersection(L, centre)
    jpoly_abs = L.polygon_ring(seg["polygon_token"])
    origin = jpoly_abs.mean(axis=0)
    half = cfg.size_m / 2
    notes: list[str] = []

    def local(p: np.ndarray) -> np.ndarray:
        return np.asarray(p, float) - origin

    jpoly = local(jpoly_abs)
    conn_paths = {}
    for rec in data["lane_connector"]:
        line = L.centreline(rec["token"])
        if line is not None and geo.points_in_polygon(local(line)[len(line) // 2:len(line) // 2 + 1], jpoly)[0]:
            conn_paths[rec["token"]] = local(line)
    lane_lines = {}
    lane_width = {}
    for rec in data["lane"]:
        if rec.get("lane_type", "CAR") != "CAR":
            continue
        line = L.centreline(rec["token"])
        if line is None:
            continue
        line = local(line)
        inside = np.max(np.abs(line), axis=1) <= half
        if inside.sum() < 2:
            continue
        lane_lines[rec["token"]] = line
        poly = L.polygon_ring(rec["polygon_token"]) if rec.get("polygon_token") in L.polygon else None
        length = float(geo.cumulative_length(line)[-1])
        if poly is not None and length > 0:
            x, y = poly[:, 0], poly[:, 1]
            area = 0.5 * abs(np.dot(x, np.roll(y, 1)) - np.dot(y, np.roll(x, 1)))
            lane_width[rec["token"]] = float(np.clip(area / length, *cfg.lane_width_range))
    connectivity = data["connectivity"]
    links = []  # (in lane token, connector token, out lane token)
    for ct in conn_paths:
        ins = [t for t in connectivity.get(ct, {}).get("incoming", []) if t in lane_lines]
        outs = [t for t in connectivity.get(ct, {}).get("outgoing", []) if t in lane_lines]
        links += [(i, ct, o) for i in ins for o in outs]
    if not links:
        raise MapError(f"{where}: no lane connector of intersection {seg['token']!r} links two lanes")
    inbound = sorted({i for i, _, _ in links})
    outbound = sorted({o for _, _, o in links})
    if set(inbound) & set(outbound):
        raise MapError(f"{where}: lanes {sorted(set(inbound) & set(outbound))} both enter and leave the junction")

    # clip each lane to the square (keep the piece touching the junction) and group into arms
    lines = {}
    for t in inbound + outbound:
        line = lane_lines[t]
        inside = np.max(np.abs(line), axis=1) <= half
        idx = np.flatnonzero(inside)
        lines[t] = line[idx[0]:idx[-1] + 1]
    junction_end = {t: (lines[t][-1] if t in inbound else lines[t][0]) for t in lines}
    bearing = {t: math.atan2(p[1], p[0]) for t, p in junction_end.items()}
    arms_of: list[list[str]] = []
    for t in sorted(lines, key=lambda t: bearing[t]):
        if arms_of and abs(math.remainder(bearing[t] - bearing[arms_of[-1][0]], 2 * math.pi)) < math.radians(35):
            arms_of[-1].append(t)
        else:
            arms_of.append([t])
    if len(arms_of) > 1 and abs(math.remainder(bearing[arms_of[0][0]] - bearing[arms_of[-1][0]], 2 * math.pi)) < math.radians(35):
        arms_of[0] = arms_of.pop() + arms_of[0]
    if len(arms_of) < 3:
        raise MapError(f"{where}: intersection {seg['token']!r} has {len(arms_of)} approaches; need at least 3")

    arms, lanes, lane_id = [], [], {}
    angles = []
    for k, tokens in enumerate(arms_of):
        a = math.atan2(np.mean([math.sin(bearing[t]) for t in tokens]), np.mean([math.cos(bearing[t]) for t in tokens]))
        out_dir = np.array([math.cos(a), math.sin(a)])
        right = np.array([out_dir[1], -out_dir[0]])
        reach = max(float(np.max(lines[t] @ out_dir)) for t in tokens)
        mouth = float(min(junction_end[t] @ out_dir for t in tokens))
        arm = Arm(id=k, name=f"approach {k}", highway="", centreline=np.array([[0.0, 0.0], out_dir * max(reach, mouth + 1)]),
                  mouth=max(mouth, 0.0), lanes_in=[], lanes_out=[], source_ids=sorted(tokens))
        for direction, ids, sign in (("in", arm.lanes_in, -1.0), ("out", arm.lanes_out, 1.0)):
            members = [t for t in tokens if (t in inbound) == (direction == "in")]
            members.sort(key=lambda t: sign * float(junction_end[t] @ right))  # leftmost first
            for index, t in enumerate(members):
                lane_id[t] = len(lanes)
                lanes.append(Lane(id=len(lanes), arm=k, direction=direction, index=index,
                                  width=lane_width.get(t, cfg.lane_width), centreline=lines[t]))
                ids.append(lane_id[t])
        arms.append(arm)
        angles.append(a)

    connectors = []
    for i, ct, o in links:
        path = conn_paths[ct]
        d0, d1 = path[1] - path[0], path[-1] - path[-2]
        turn = math.remainder(math.atan2(d1[1], d1[0]) - math.atan2(d0[1], d0[0]), 2 * math.pi)
        movement = ("straight" if abs(turn) < cfg.straight_angle else "uturn" if abs(turn) > cfg.uturn_angle
                    else "left" if turn > 0 else "right")
        if movement == "uturn":
            continue
        connectors.append(Connector(id=len(connectors), from_lane=lane_id[i], to_lane=lane_id[o], movement=movement,
                                    path=path, min_radius=geo.min_radius(path)))
    mark_conflicts(connectors)

    def nearest_arm(p: np.ndarray, need_in: bool) -> Optional[int]:
        b = math.atan2(p[1], p[0])
        cands = [(abs(math.remainder(b - angles[k], 2 * math.pi)), k) for k in range(len(arms))
                 if arms[k].lanes_in or not need_in]
        best = min(cands, default=None)
        return None if best is None or best[0] > math.radians(45) else best[1]

    stop_lines = []
    for rec in data.get("stop_line", []):
        poly = local(L.polygon_ring(rec["polygon_token"]))
        c = poly.mean(axis=0)
        k = nearest_arm(c, True) if np.max(np.abs(c)) <= half else None
        if k is None:
            continue
        s = float(c @ arms[k].centreline[-1] / np.linalg.norm(arms[k].centreline[-1]))
        prev = next((x for x in stop_lines if x.arm == k), None)
        if prev is None or s < prev.s:
            stop_lines = [x for x in stop_lines if x.arm != k] + [StopLine(arm=k, s=s, segment=geo.long_axis(poly))]
    for arm in arms:
        if arm.lanes_in and not any(x.arm == arm.id for x in stop_lines):
            ends = np.array([lanes[t].centreline[-1] for t in arm.lanes_in])
            seg = ends[[0, -1]] if len(ends) > 1 else np.array([ends[0] - 1e-3, ends[0] + 1e-3])
            stop_lines.append(StopLine(arm=arm.id, s=arm.mouth, segment=seg))
            notes.append(f"approach {arm.id}: no stop line in the data; one at the lane ends")
    stop_lines.sort(key=lambda x: x.arm)

    signals = []
    lights = [t for t in data.get("traffic_light", [])]
    found: dict[int, Any] = {}
    for rec in lights:
        pose = rec.get("pose", {})
        p = local(np.array([pose.get("tx", np.nan), pose.get("ty", np.nan)], float))
        if not np.all(np.isfinite(p)) and rec.get("line_token") in L.line:
            p = local(L.ring(L.line[rec["line_token"]]["node_tokens"]).mean(axis=0))
        if np.all(np.isfinite(p)) and np.max(np.abs(p)) <= half:
            k = nearest_arm(p, True)
            if k is not None and k not in found:
                found[k] = rec["token"]
    if found:
        groups = signal_groups(angles, [len(a.lanes_in) for a in arms], [len(a.lanes_out) for a in arms])
        for line in stop_lines:
            signals.append(SignalHead(id=len(signals), arm=line.arm, group=groups[line.arm],
                                      position=line.segment.mean(axis=0), source_id=found.get(line.arm),
                                      inferred=line.arm not in found))
            if line.arm not in found:
                notes.append(f"approach {line.arm}: no traffic light found; signal head inferred")
    crosswalks = []
    for rec in data.get("ped_crossing", []):
        poly = local(L.polygon_ring(rec["polygon_token"]))
        c = poly.mean(axis=0)
        k = nearest_arm(c, False) if np.max(np.abs(c)) <= half else None
        if k is not None:
            s = float(c @ arms[k].centreline[-1] / np.linalg.norm(arms[k].centreline[-1]))
            crosswalks.append(Crosswalk(arm=k, s=s, polygon=poly, kind="ped_crossing", source_id=rec["token"]))

    drivable = [jpoly]
    edges: list[np.ndarray] = []
    for rec in data.get("drivable_area", []):
        for token in rec.get("polygon_tokens", []):
            ring = local(L.polygon_ring(token))
            clipped = geo.clip_polygon_to_square(ring, half)
            if len(clipped):
                drivable.append(clipped)
            for r in [ring] + [local(h) for h in L.polygon_holes(token)]:
                edges += geo.clip_ring_to_square(r, half)
    if not edges:
        raise MapError(f"{where}: no drivable_area boundary near intersection {seg['token']!r}")
    area = geo.convex_hull(np.vstack([jpoly] + [x.segment for x in stop_lines]))

    spawns = []
    for lane in lanes:
        if lane.direction == "in":
            track = TrackPath.from_points(lane.centreline)
            line = next(x for x in stop_lines if x.arm == lane.arm)
            hi = track.project(line.segment.mean(axis=0)) - cfg.spawn_gap
            if hi > 0:
                spawns.append(SpawnRegion(lane=lane.id, s_range=(0.0, float(hi))))
    source = {"kind": "nuscenes-map-expansion", "file": None if isinstance(source, dict) else Path(source).name,
              "road_segment": seg["token"], "centre_xy": [float(v) for v in origin], **LICENCE}
    return RoadMap(name=name or f"nuscenes_{seg['token'][:8]}", source=source, size_m=cfg.size_m, arms=arms,
                   lanes=lanes, connectors=connectors, stop_lines=stop_lines, signals=signals,
                   phases=[[g] for g in sorted({h.group for h in signals})], crosswalks=crosswalks,
                   drivable=drivable, edges=edges, spawn_regions=spawns, junction_area=area,
                   notes=list(dict.fromkeys(notes)))


def _pick_intersection(L: _Layers, centre: Union[tuple[float, float], str, None]) -> dict:
    inters = [r for r in L.data["road_segment"] if r.get("is_intersection")]
    if not inters:
        raise MapError(f"{L.where}: no road_segment with is_intersection")
    if isinstance(centre, str):
        match = [r for r in inters if r["token"] == centre]
        if not match:
            raise MapError(f"{L.where}: no intersection road_segment {centre!r}")
        return match[0]
    if centre is None:
        if len(inters) > 1:
            raise MapError(f"{L.where}: {len(inters)} intersections; give centre=(x, y) or a road_segment token")
        return inters[0]
    p = np.asarray(centre, float)
    containing = [r for r in inters if geo.points_in_polygon(p[None], L.polygon_ring(r["polygon_token"]))[0]]
    if containing:
        return containing[0]
    return min(inters, key=lambda r: float(np.linalg.norm(L.polygon_ring(r["polygon_token"]).mean(axis=0) - p)))
