"""A small hand-built nuScenes map-expansion file: a four-way junction centred at (500, 300).

Each approach k (outward direction k * 90 degrees, 0 = east) has one inbound and one outbound lane
of 3.5 m (right-hand traffic); from each inbound lane: straight, left (radius 9.75 m) and right
(radius 6.25 m) connectors as arcline paths; a stop line, a traffic light and a pedestrian
crossing on each approach; one drivable-area polygon (a plus shape).
"""

from __future__ import annotations

import math

import numpy as np

CENTRE = np.array([500.0, 300.0])
HALF_BOX = 8.0  # the intersection polygon is the square |x|, |y| <= 8 (local)
ARM = 60.0
LANE = 3.5


class _Builder:
    def __init__(self) -> None:
        self.data = {k: [] for k in ("node", "line", "polygon", "drivable_area", "road_segment", "lane",
                                     "lane_connector", "stop_line", "traffic_light", "ped_crossing")}
        self.data.update(version="1.3", arcline_path_3={}, connectivity={})
        self.n = 0

    def token(self, kind: str) -> str:
        self.n += 1
        return f"{kind}-{self.n:04d}"

    def nodes(self, points) -> list[str]:
        tokens = []
        for x, y in np.asarray(points, float) + CENTRE:
            tokens.append(self.token("node"))
            self.data["node"].append({"token": tokens[-1], "x": float(x), "y": float(y)})
        return tokens

    def polygon(self, points) -> str:
        t = self.token("poly")
        self.data["polygon"].append({"token": t, "exterior_node_tokens": self.nodes(points), "holes": []})
        return t

    def line(self, points) -> str:
        t = self.token("line")
        self.data["line"].append({"token": t, "node_tokens": self.nodes(points)})
        return t


def _rot(k: int) -> np.ndarray:
    c, s = math.cos(k * math.pi / 2), math.sin(k * math.pi / 2)
    return np.array([[c, -s], [s, c]])


def _pose(p, yaw, k):
    q = _rot(k) @ np.asarray(p, float) + CENTRE
    return [float(q[0]), float(q[1]), float(yaw + k * math.pi / 2)]


def four_way_nuscenes() -> dict:
    b = _Builder()
    d = b.data
    half = LANE
    # drivable area: a plus shape of 7 m wide roads, 60 m arms
    plus = []
    for k in range(4):
        r = _rot(k)
        plus += [r @ np.array([HALF_BOX, -half]), r @ np.array([ARM, -half]), r @ np.array([ARM, half]),
                 r @ np.array([HALF_BOX, half])]
    # corners at the box: insert box corners between arms
    ring = []
    for k in range(4):
        ring += plus[4 * k: 4 * k + 4]
        ring.append(_rot(k) @ np.array([HALF_BOX, HALF_BOX]))
    d["drivable_area"].append({"token": b.token("da"), "polygon_tokens": [b.polygon(ring)]})
    seg_poly = b.polygon([[-HALF_BOX, -HALF_BOX], [HALF_BOX, -HALF_BOX], [HALF_BOX, HALF_BOX], [-HALF_BOX, HALF_BOX]])
    d["road_segment"].append({"token": "junction-0001", "polygon_token": seg_poly, "is_intersection": True})
    inbound, outbound = {}, {}
    for k in range(4):  # approach k lies in direction k * 90 degrees
        r = _rot(k)
        lane_in = b.token("lane")  # drives towards the centre on the right: y = +1.75 in the arm frame
        d["lane"].append({"token": lane_in, "lane_type": "CAR",
                          "polygon_token": b.polygon([r @ np.array(p) for p in
                                                      ([HALF_BOX, 0], [ARM, 0], [ARM, LANE], [HALF_BOX, LANE])])})
        d["arcline_path_3"][lane_in] = [{"start_pose": _pose([ARM, LANE / 2], math.pi, k),
                                         "end_pose": _pose([HALF_BOX, LANE / 2], math.pi, k), "shape": "SSS",
                                         "radius": 999.0, "segment_length": [ARM - HALF_BOX, 0.0, 0.0]}]
        lane_out = b.token("lane")
        d["lane"].append({"token": lane_out, "lane_type": "CAR",
                          "polygon_token": b.polygon([r @ np.array(p) for p in
                                                      ([HALF_BOX, -LANE], [ARM, -LANE], [ARM, 0], [HALF_BOX, 0])])})
        d["arcline_path_3"][lane_out] = [{"start_pose": _pose([HALF_BOX, -LANE / 2], 0.0, k),
                                          "end_pose": _pose([ARM, -LANE / 2], 0.0, k), "shape": "SSS",
                                          "radius": 999.0, "segment_length": [ARM - HALF_BOX, 0.0, 0.0]}]
        inbound[k], outbound[k] = lane_in, lane_out
        stop = b.polygon([r @ np.array(p) for p in ([HALF_BOX + 4.0, 0], [HALF_BOX + 4.5, 0],
                                                     [HALF_BOX + 4.5, LANE], [HALF_BOX + 4.0, LANE])])
        light = b.token("tl")
        d["traffic_light"].append({"token": light, "line_token": b.line([r @ np.array([HALF_BOX + 4.2, LANE + 0.5]),
                                                                          r @ np.array([HALF_BOX + 4.2, LANE + 1.0])]),
                                   "pose": {"tx": float((r @ np.array([HALF_BOX + 4.2, LANE + 0.7]) + CENTRE)[0]),
                                            "ty": float((r @ np.array([HALF_BOX + 4.2, LANE + 0.7]) + CENTRE)[1]),
                                            "tz": 0.0, "rx": 0.0, "ry": 0.0, "rz": 0.0},
                                   "items": [], "traffic_light_type": "VERTICAL", "from_road_block_token": ""})
        d["stop_line"].append({"token": b.token("sl"), "polygon_token": stop, "stop_line_type": "TRAFFIC_LIGHT",
                               "ped_crossing_tokens": [], "traffic_light_tokens": [light]})
        d["ped_crossing"].append({"token": b.token("pc"), "polygon_token": b.polygon(
            [r @ np.array(p) for p in ([HALF_BOX + 0.5, -LANE], [HALF_BOX + 3.5, -LANE],
                                       [HALF_BOX + 3.5, LANE], [HALF_BOX + 0.5, LANE])])})
    for k in range(4):
        # entering from approach k: heading k*90 + 180; in the arm-k frame start at (8, 1.75), yaw pi
        start = [HALF_BOX, LANE / 2]
        moves = {
            "straight": ((k + 2) % 4, "SSS", 999.0, [2 * HALF_BOX, 0.0, 0.0]),
            "left": ((k + 3) % 4, "LSS", HALF_BOX + LANE / 2, [math.pi / 2 * (HALF_BOX + LANE / 2), 0.0, 0.0]),
            "right": ((k + 1) % 4, "RSS", HALF_BOX - LANE / 2, [math.pi / 2 * (HALF_BOX - LANE / 2), 0.0, 0.0]),
        }
        for target, shape, radius, lengths in moves.values():
            ct = b.token("lc")
            d["lane_connector"].append({"token": ct, "polygon_token": seg_poly})
            d["arcline_path_3"][ct] = [{"start_pose": _pose(start, math.pi, k), "end_pose": [0, 0, 0],
                                        "shape": shape, "radius": radius, "segment_length": lengths}]
            d["connectivity"][ct] = {"incoming": [inbound[k]], "outgoing": [outbound[target]]}
    return d
