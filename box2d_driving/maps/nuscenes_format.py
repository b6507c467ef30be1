"""Reading the nuScenes map-expansion format: token lookups over its layers, the lane centre
lines its ``arcline_path_3`` records describe, and which ``road_segment`` is the junction asked for.
:mod:`box2d_driving.maps.nuscenes` builds the junction from them."""

from __future__ import annotations

import math
from typing import Optional, Union

import numpy as np

from box2d_driving.maps import geometry as geo
from box2d_driving.maps.roadmap import MapError

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


class Layers:
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


def pick_intersection(L: Layers, centre: Union[tuple[float, float], str, None]) -> dict:
    """The intersection ``road_segment`` asked for: by token, the only one (``centre`` None), the
    one containing the point ``centre``, else the one whose polygon's centroid is nearest it."""
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
