"""Turn source-independent arm descriptions into a :class:`RoadMap`.

An importer (OSM, or a user's own) describes each road leaving the junction as an
:class:`ArmSpec`: its axis from the junction centre outwards, lane counts and width, turn lanes,
signals and crossings found on it. :func:`build_map` then lays out lanes, finds where each arm's
own carriageway starts (its *mouth*: beyond the overlap with its neighbours, plus a curb radius),
rounds the corners between neighbouring arms, places crosswalks and stop lines, joins inbound to
outbound lanes with connectors (Bezier curves, checked for radius and for staying on the road),
marks conflicting connectors and groups the signals into a two-phase plan.

Lateral positions ``u`` are measured to the right of an arm's outward direction. The carriageway
is centred on the axis: inbound lanes to the left of ``split``, outbound lanes to its right.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Optional

import numpy as np

from box2d_driving.maps import geometry as geo
from box2d_driving.maps.config import ImportConfig
from box2d_driving.maps.mirror import FLIP_Y, mirror_map, swap_turn
from box2d_driving.maps.roadmap import (Arm, Connector, Crosswalk, Lane, MapError, RoadMap, SignalHead,
                                        SpawnRegion, StopLine)


@dataclass
class ArmSpec:
    """One road leaving the junction, as an importer found it.

    Attributes:
        centreline: ``(P, 2)`` axis from the junction centre outwards (m).
        lanes_in / lanes_out: lane counts towards / away from the junction.
        lane_width: (m).
        median: extra width between the two directions (dual carriageways) (m).
        turn_lanes: per inbound lane, left to right, the allowed movements, or None.
        signals: ``(position, source_id)`` of signal heads found for this approach.
        crossings: ``(s, kind, source_id)`` of pedestrian crossings, ``s`` along the axis (m).
    """

    centreline: np.ndarray
    lanes_in: int
    lanes_out: int
    lane_width: float
    name: str = ""
    highway: str = ""
    median: float = 0.0
    turn_lanes: Optional[list[set[str]]] = None
    cut: bool = False
    source_ids: list[int] = field(default_factory=list)
    signals: list[tuple[np.ndarray, Optional[int]]] = field(default_factory=list)
    crossings: list[tuple[float, str, Optional[int]]] = field(default_factory=list)

    @property
    def width(self) -> float:
        return (self.lanes_in + self.lanes_out) * self.lane_width + self.median

    @property
    def split(self) -> float:
        return (self.lanes_in - self.lanes_out) * self.lane_width / 2

    @property
    def u_left(self) -> float:
        return -self.width / 2

    @property
    def u_right(self) -> float:
        return self.width / 2

    @property
    def length(self) -> float:
        return float(geo.cumulative_length(self.centreline)[-1])

    def lane_u(self, direction: str, index: int) -> float:
        """Lateral position of a lane's centre; ``index`` 0 is the leftmost in its direction."""
        if direction == "out":
            return self.split + self.median / 2 + (index + 0.5) * self.lane_width
        return self.split - self.median / 2 - (index + 0.5) * self.lane_width


def arm_angle(centreline: np.ndarray, at: float = 15.0) -> float:
    """Outward direction of an arm: from the centre to the point ``at`` metres out (rad)."""
    p = geo.point_at(centreline, at) - centreline[0]
    return math.atan2(p[1], p[0])


def _wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


def _strip(spec: ArmSpec, start: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Left and right edges of the arm's carriageway from arc length ``start`` outwards."""
    axis = geo.resample(spec.centreline, 1.0, start)
    return geo.offset(axis, spec.u_left), geo.offset(axis, spec.u_right)


def _mouths(specs: list[ArmSpec], cfg: ImportConfig) -> list[float]:
    """Arc length where each arm stops overlapping the other arms' carriageways, plus the curb."""
    polys = [np.vstack([l, r[::-1]]) for l, r in (_strip(s) for s in specs)]
    out = []
    for i, spec in enumerate(specs):
        last = 0.0
        for s in np.arange(0.0, spec.length, 0.5):
            p = geo.point_at(spec.centreline, s)
            t = geo.tangent_at(spec.centreline, s)
            n = np.array([t[1], -t[0]])
            a, b = p + spec.u_left * n, p + spec.u_right * n
            if any(geo.segment_hits_polygon(a, b, polys[j]) for j in range(len(specs)) if j != i):
                last = s
        mouth = last + cfg.curb_radius
        if mouth > spec.length - cfg.min_arm_length / 2:
            raise MapError(f"arm {spec.name or i!r}: its neighbours overlap it up to {last:.0f} m of its "
                           f"{spec.length:.0f} m; too short or too acute to lay out")
        out.append(mouth)
    return out


def _corner(p0: np.ndarray, d0: np.ndarray, p2: np.ndarray, d2: np.ndarray, samples: int) -> np.ndarray:
    """Rounded curb from ``p0`` (heading ``d0`` into the junction) to ``p2`` (leaving along -d2)."""
    hit = geo.line_intersection(p0, d0, p2, d2)
    chord = np.linalg.norm(p2 - p0)
    if hit is None or not (0 < hit[0] < 3 * chord + 1 and 0 < hit[1] < 3 * chord + 1):
        return np.array([p0, p2])
    return geo.bezier(p0, p0 + hit[0] * d0, p2, samples=samples)


def _movement(turn: float, cfg: ImportConfig) -> str:
    if abs(turn) < cfg.straight_angle:
        return "straight"
    if abs(turn) > cfg.uturn_angle:
        return "uturn"
    return "left" if turn > 0 else "right"


def _default_turns(n: int) -> list[set[str]]:
    if n == 1:
        return [{"left", "straight", "right"}]
    return [{"left", "straight"}] + [{"straight"}] * (n - 2) + [{"straight", "right"}]


def build_map(specs: list[ArmSpec], cfg: ImportConfig, name: str, source: dict,
              signalled: bool = False, notes: Optional[list[str]] = None) -> RoadMap:
    """Lay out a junction from its arms (see the module docstring) for traffic keeping to
    ``cfg.drive_on``.

    ``signalled``: the junction has signals even if no arm found its own head (e.g. the junction
    node itself is tagged); every approach then gets one.
    """
    if cfg.drive_on == "left":  # the mirror image of a right-hand junction (maps/mirror.py)
        mirrored = _build([_mirror_spec(s) for s in specs], cfg, name, {**source, "drive_on": "left"},
                          signalled, notes, mirrored=True)
        return mirror_map(mirrored)
    return _build(specs, cfg, name, source, signalled, notes, mirrored=False)


def _mirror_spec(spec: ArmSpec) -> ArmSpec:
    """The arm reflected across the x axis; its turn lanes (listed left to right) reversed, with
    left and right turns swapped."""
    turns = None if spec.turn_lanes is None else [{swap_turn(m) for m in t} for t in spec.turn_lanes[::-1]]
    return replace(spec, centreline=spec.centreline * FLIP_Y, turn_lanes=turns,
                   signals=[(p * FLIP_Y, sid) for p, sid in spec.signals], crossings=list(spec.crossings))


def _build(specs: list[ArmSpec], cfg: ImportConfig, name: str, source: dict, signalled: bool,
           notes: Optional[list[str]], mirrored: bool) -> RoadMap:
    """:func:`build_map` for right-hand traffic; ``mirrored``: the specs are a left-hand
    junction's mirror image (notes then name turns and lanes as they are in reality)."""
    def shown_lane(lane: Lane) -> int:
        count = (specs[lane.arm].lanes_in if lane.direction == "in" else specs[lane.arm].lanes_out)
        return count - 1 - lane.index if mirrored else lane.index

    def shown_turn(movement: str) -> str:
        return swap_turn(movement) if mirrored else movement

    notes = list(notes or [])
    if len(specs) < 3:
        raise MapError(f"{name}: a junction needs at least 3 arms, found {len(specs)}")
    order = np.argsort([arm_angle(s.centreline) for s in specs])
    specs = [specs[i] for i in order]
    for s in specs:
        s.centreline = geo.resample(s.centreline, cfg.sample_step)
    mouths = _mouths(specs, cfg)
    angles = [arm_angle(s.centreline) for s in specs]

    # ---- lanes ---------------------------------------------------------------------------------
    arms, lanes = [], []
    for i, (spec, mouth) in enumerate(zip(specs, mouths)):
        axis = geo.resample(spec.centreline, cfg.sample_step / 2, mouth)
        arm = Arm(id=i, name=spec.name, highway=spec.highway, centreline=spec.centreline, mouth=mouth,
                  lanes_in=[], lanes_out=[], cut=spec.cut, source_ids=list(spec.source_ids))
        for direction, count, ids in (("in", spec.lanes_in, arm.lanes_in), ("out", spec.lanes_out, arm.lanes_out)):
            for k in range(count):
                line = geo.offset(axis, spec.lane_u(direction, k))
                lanes.append(Lane(id=len(lanes), arm=i, direction=direction, index=k,
                                  width=spec.lane_width, centreline=line[::-1] if direction == "in" else line))
                ids.append(lanes[-1].id)
        arms.append(arm)

    # ---- edges, drivable area ------------------------------------------------------------------
    edges, drivable, junction, corners = [], [], [], []
    for i, (spec, mouth) in enumerate(zip(specs, mouths)):
        left, right = _strip(spec, mouth)
        edges += [left, right]
        if spec.median > 0:  # a dual carriageway: the median is kerbed, not drivable
            axis = geo.resample(spec.centreline, 1.0, mouth)
            inner_in = geo.offset(axis, spec.split - spec.median / 2)
            inner_out = geo.offset(axis, spec.split + spec.median / 2)
            edges += [inner_in, inner_out, np.array([inner_in[0], inner_out[0]])]  # sides and nose
            drivable += [np.vstack([left, inner_in[::-1]]), np.vstack([inner_out, right[::-1]])]
        else:
            drivable.append(np.vstack([left, right[::-1]]))
        j = (i + 1) % len(specs)
        nxt_left, nxt_right = _strip(specs[j], mouths[j])
        corner = _corner(left[0], -geo.tangent_at(spec.centreline, mouth), nxt_right[0],
                         -geo.tangent_at(specs[j].centreline, mouths[j]), cfg.corner_samples)
        edges.append(corner)
        junction += [right[0], left[0], *corner[1:-1]]
        corners.append(corner)
    drivable.insert(0, np.array(junction))
    boundary = list(edges)

    def on_road(points: np.ndarray) -> np.ndarray:
        inside = np.zeros(len(points), dtype=bool)
        for poly in drivable:
            inside |= geo.points_in_polygon(points, poly)
        return inside & (geo.distance_to_polylines(points, boundary) >= cfg.edge_clearance)

    # ---- crosswalks and stop lines -------------------------------------------------------------
    crosswalks, stop_lines = [], []
    for i, (spec, mouth) in enumerate(zip(specs, mouths)):
        stop = mouth + cfg.stop_margin
        for s, kind, sid in sorted(spec.crossings):
            s = max(s, mouth + cfg.crosswalk_width / 2)
            if s - mouth > cfg.crosswalk_reach or s + cfg.crosswalk_width / 2 > spec.length - cfg.min_arm_length / 2:
                notes.append(f"crossing {sid} on arm {spec.name!r} at {s:.0f} m left out (too far from the junction)")
                continue
            if any(abs(c.s - s) < cfg.crosswalk_width for c in crosswalks if c.arm == i):
                continue
            c = geo.point_at(spec.centreline, s)
            t = geo.tangent_at(spec.centreline, s)
            n = np.array([t[1], -t[0]])
            h = cfg.crosswalk_width / 2
            poly = np.array([c - h * t + spec.u_right * n, c + h * t + spec.u_right * n,
                             c + h * t + spec.u_left * n, c - h * t + spec.u_left * n])
            crosswalks.append(Crosswalk(arm=i, s=float(s), polygon=poly, kind=kind, source_id=sid))
            stop = max(stop, s + h + cfg.stop_margin)
        if spec.lanes_in:
            p = geo.point_at(spec.centreline, stop)
            t = geo.tangent_at(spec.centreline, stop)
            n = np.array([t[1], -t[0]])
            inner = spec.split - spec.median / 2
            stop_lines.append(StopLine(arm=i, s=float(stop), segment=np.array([p + inner * n, p + spec.u_left * n])))

    # ---- junction area: out to the stop lines, or past the crosswalks of outbound-only arms -----
    area = []
    for i, (spec, mouth) in enumerate(zip(specs, mouths)):
        line = next((s for s in stop_lines if s.arm == i), None)
        ext = line.s if line is not None else max([mouth] + [c.s + cfg.crosswalk_width / 2
                                                            for c in crosswalks if c.arm == i])
        left, right = _strip(spec, mouth)
        cum = geo.cumulative_length(left)
        k = int(np.searchsorted(cum, ext - mouth))
        up_right = np.vstack([right[:k], geo.point_at(right, ext - mouth)])  # outwards
        down_left = np.vstack([geo.point_at(left, ext - mouth), left[:k][::-1]])  # back in
        area += [*up_right, *down_left, *corners[i][1:-1]]
    junction_area = geo.dedupe(np.array(area))

    # ---- connectors ----------------------------------------------------------------------------
    connectors: list[Connector] = []
    for i, spec in enumerate(specs):
        if not spec.lanes_in:
            continue
        turns = spec.turn_lanes if spec.turn_lanes and len(spec.turn_lanes) == spec.lanes_in else None
        if spec.turn_lanes and turns is None:
            notes.append(f"arm {spec.name!r}: turn:lanes lists {len(spec.turn_lanes)} lanes, not "
                         f"{spec.lanes_in}; default turn lanes used")
        allowed = turns or _default_turns(spec.lanes_in)
        targets = []  # (arm j, movement)
        for j, other in enumerate(specs):
            if j != i and other.lanes_out:
                movement = _movement(_wrap(angles[j] - _wrap(angles[i] + math.pi)), cfg)
                if movement != "uturn":
                    targets.append((j, movement))
        possible = {m for _, m in targets}
        allowed = [a & possible or set(possible) for a in allowed]  # a lane with no such arm serves all
        for j, movement in targets:
            from_lanes = [arms[i].lanes_in[k] for k in range(spec.lanes_in) if movement in allowed[k]]
            to_lanes = list(arms[j].lanes_out)
            if movement == "right":
                from_lanes, to_lanes = from_lanes[::-1], to_lanes[::-1]
            for k, fl in enumerate(from_lanes):
                tl = to_lanes[min(k, len(to_lanes) - 1)]
                a, b = lanes[fl].centreline, lanes[tl].centreline
                p0, p3 = a[-1], b[0]
                d0 = (a[-1] - a[-2]) / np.linalg.norm(a[-1] - a[-2])
                d3 = (b[1] - b[0]) / np.linalg.norm(b[1] - b[0])
                h = cfg.connector_handle * np.linalg.norm(p3 - p0)
                path = geo.bezier(p0, p0 + h * d0, p3 - h * d3, p3)
                radius = geo.min_radius(path)
                label = (f"{shown_turn(movement)} from {spec.name!r} lane {shown_lane(lanes[fl])} "
                         f"to {specs[j].name!r} lane {shown_lane(lanes[tl])}")
                if radius < cfg.min_turn_radius:
                    notes.append(f"connector {label} left out: radius {radius:.1f} m")
                    continue
                if not on_road(path).all():
                    notes.append(f"connector {label} left out: it leaves the carriageway")
                    continue
                connectors.append(Connector(id=len(connectors), from_lane=fl, to_lane=tl, movement=movement,
                                            path=path, min_radius=radius))
    mark_conflicts(connectors)
    served = {c.from_lane for c in connectors}
    for lane in lanes:
        if lane.direction == "in" and lane.id not in served:
            notes.append(f"inbound lane {shown_lane(lane)} of {specs[lane.arm].name!r} has no connector")

    # ---- signals -------------------------------------------------------------------------------
    signals: list[SignalHead] = []
    phases: list[list[int]] = []
    if signalled or any(s.signals for s in specs):
        groups = signal_groups(angles, [s.lanes_in for s in specs], [s.lanes_out for s in specs])
        for i, spec in enumerate(specs):
            line = next((s for s in stop_lines if s.arm == i), None)
            if line is None:
                continue
            found = spec.signals[0] if spec.signals else None
            signals.append(SignalHead(id=len(signals), arm=i, group=groups[i], position=line.segment.mean(axis=0),
                                      source_id=None if found is None else found[1], inferred=found is None))
            if found is None:
                notes.append(f"approach {spec.name!r}: no signal node found; signal head inferred")
        phases = [[g] for g in sorted({h.group for h in signals})]

    spawns = []
    for lane in lanes:
        if lane.direction == "in":
            line = next(s for s in stop_lines if s.arm == lane.arm)
            length = float(geo.cumulative_length(lane.centreline)[-1])
            hi = length - (line.s - mouths[lane.arm]) - cfg.spawn_gap
            if hi > 0:
                spawns.append(SpawnRegion(lane=lane.id, s_range=(0.0, hi)))
    return RoadMap(name=name, source=source, size_m=cfg.size_m, arms=arms, lanes=lanes, connectors=connectors,
                   stop_lines=stop_lines, signals=signals, phases=phases, crosswalks=crosswalks,
                   drivable=drivable, edges=edges, spawn_regions=spawns, junction_area=junction_area,
                   notes=list(dict.fromkeys(notes)))


def mark_conflicts(connectors: list[Connector]) -> None:
    """Connectors from different lanes conflict if their paths cross or they end on one lane."""
    for c in connectors:
        c.conflicts = [d.id for d in connectors if d.from_lane != c.from_lane
                       and (d.to_lane == c.to_lane or geo.polylines_cross(c.path, d.path))]


def signal_groups(angles: list[float], lanes_in: list[int], lanes_out: list[int]) -> list[int]:
    """Two-phase plan: the busiest approach and the approaches roughly opposite it (or parallel
    to it) are group 0; the crossing approaches are group 1. ``angles``: outward arm directions."""
    lead = max(range(len(angles)), key=lambda i: (lanes_in[i], lanes_in[i] + lanes_out[i]))
    return [0 if abs(math.cos(angles[i] - angles[lead])) >= math.cos(math.radians(45)) else 1
            for i in range(len(angles))]
