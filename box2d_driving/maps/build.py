"""Turn source-independent arm descriptions into a :class:`RoadMap`.

An importer (OSM, or a user's own) describes each road leaving the junction as an
:class:`~box2d_driving.maps.arm_spec.ArmSpec`: its axis from the junction centre outwards, lane
counts and width, turn lanes, signals and crossings found on it. :func:`build_map` then lays out
lanes, finds where each arm's own carriageway starts (its *mouth*: beyond the overlap with its
neighbours, plus a curb radius), rounds the corners between neighbouring arms, places crosswalks
and stop lines, joins inbound to outbound lanes with connectors (``connectors.py``: Bezier
curves, checked for radius and for staying on the road, conflicts marked) and groups the signals
into a two-phase plan. Each step is one function below, in the order :func:`_build` calls them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from functools import partial
from typing import Optional

import numpy as np

from box2d_driving.maps import geometry as geo
from box2d_driving.maps.arm_spec import ArmSpec, arm_angle, checked_spec, strip
from box2d_driving.maps.config import ImportConfig
from box2d_driving.maps.connectors import TurnNaming, connect_lanes
from box2d_driving.maps.mirror import FLIP_Y, mirror_map, swap_turn
from box2d_driving.maps.roadmap import (Arm, Crosswalk, Lane, MapError, RoadMap, SignalHead,
                                        SpawnRegion, StopLine)


def _mouths(specs: list[ArmSpec], cfg: ImportConfig) -> list[float]:
    """Arc length where each arm stops overlapping the other arms' carriageways, plus the curb."""
    polys = [np.vstack([left, right[::-1]]) for left, right in (strip(s) for s in specs)]
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


def build_map(specs: list[ArmSpec], cfg: ImportConfig, name: str, source: dict,
              signalled: bool = False, notes: Optional[list[str]] = None) -> RoadMap:
    """Lay out a junction from its arms (see the module docstring) for traffic keeping to
    ``cfg.drive_on``.

    ``signalled``: the junction has signals even if no arm found its own head (e.g. the junction
    node itself is tagged); every approach then gets one. :class:`MapError` names an arm whose
    values cannot describe a road, or a junction that cannot be laid out.
    """
    if len(specs) < 3:
        raise MapError(f"{name}: a junction needs at least 3 arms, found {len(specs)}")
    specs = [checked_spec(s, i) for i, s in enumerate(specs)]
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


@dataclass
class _Surface:
    """The carriageway: ``edges`` (curbs, medians, rounded corners), the ``drivable`` polygons (the
    junction polygon first, then each arm's), and each arm's rounded ``corners`` towards the next."""

    edges: list[np.ndarray]
    drivable: list[np.ndarray]
    corners: list[np.ndarray]

    def on_road(self, points: np.ndarray, clearance: float) -> np.ndarray:
        """Per point: inside a drivable polygon and at least ``clearance`` (m) from every edge."""
        inside = np.zeros(len(points), dtype=bool)
        for poly in self.drivable:
            inside |= geo.points_in_polygon(points, poly)
        return inside & (geo.distance_to_polylines(points, self.edges) >= clearance)


def _build(specs: list[ArmSpec], cfg: ImportConfig, name: str, source: dict, signalled: bool,
           notes: Optional[list[str]], mirrored: bool) -> RoadMap:
    """:func:`build_map` for right-hand traffic; ``mirrored``: the specs are a left-hand
    junction's mirror image (notes then name turns and lanes as they are in reality)."""
    notes = list(notes or [])
    order = np.argsort([arm_angle(s.centreline) for s in specs])
    # resampled copies: the caller's arm descriptions stay as they were
    specs = [replace(specs[i], centreline=geo.resample(specs[i].centreline, cfg.sample_step)) for i in order]
    mouths = _mouths(specs, cfg)
    angles = [arm_angle(s.centreline) for s in specs]
    arms, lanes = _lay_lanes(specs, mouths, cfg)
    surface = _lay_surface(specs, mouths, cfg)
    crosswalks, stop_lines = _place_crossings(specs, mouths, cfg, notes)
    junction_area = _junction_area(specs, mouths, surface.corners, crosswalks, stop_lines, cfg)
    on_road = partial(surface.on_road, clearance=cfg.edge_clearance)
    connectors = connect_lanes(specs, angles, arms, lanes, on_road, cfg, TurnNaming(specs, mirrored), notes)
    signals, phases = _place_signals(specs, angles, stop_lines, signalled, notes)
    return RoadMap(name=name, source=source, size_m=cfg.size_m, arms=arms, lanes=lanes, connectors=connectors,
                   stop_lines=stop_lines, signals=signals, phases=phases, crosswalks=crosswalks,
                   drivable=surface.drivable, edges=surface.edges,
                   spawn_regions=_spawn_regions(lanes, stop_lines, mouths, cfg), junction_area=junction_area,
                   notes=list(dict.fromkeys(notes)))


def _lay_lanes(specs: list[ArmSpec], mouths: list[float], cfg: ImportConfig) -> tuple[list[Arm], list[Lane]]:
    """Each arm and its lanes, from its mouth outwards; inbound lanes point towards the junction."""
    arms: list[Arm] = []
    lanes: list[Lane] = []
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
    return arms, lanes


def _lay_surface(specs: list[ArmSpec], mouths: list[float], cfg: ImportConfig) -> _Surface:
    """Curbs and medians of every arm, the rounded corners between neighbouring arms, and the
    drivable polygons they bound."""
    edges, drivable, junction, corners = [], [], [], []
    for i, (spec, mouth) in enumerate(zip(specs, mouths)):
        left, right = strip(spec, mouth)
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
        nxt_left, nxt_right = strip(specs[j], mouths[j])
        corner = _corner(left[0], -geo.tangent_at(spec.centreline, mouth), nxt_right[0],
                         -geo.tangent_at(specs[j].centreline, mouths[j]), cfg.corner_samples)
        edges.append(corner)
        junction += [right[0], left[0], *corner[1:-1]]
        corners.append(corner)
    drivable.insert(0, np.array(junction))
    return _Surface(edges=edges, drivable=drivable, corners=corners)


def _place_crossings(specs: list[ArmSpec], mouths: list[float], cfg: ImportConfig,
                     notes: list[str]) -> tuple[list[Crosswalk], list[StopLine]]:
    """Crosswalks near the junction (one per ``crosswalk_width`` of arm; far ones left out with a
    note) and each approach's stop line, behind its crosswalks."""
    crosswalks: list[Crosswalk] = []
    stop_lines: list[StopLine] = []
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
    return crosswalks, stop_lines


def _junction_area(specs: list[ArmSpec], mouths: list[float], corners: list[np.ndarray],
                   crosswalks: list[Crosswalk], stop_lines: list[StopLine], cfg: ImportConfig) -> np.ndarray:
    """The junction's polygon: out to the stop lines, or past the crosswalks of outbound-only arms."""
    area = []
    for i, (spec, mouth) in enumerate(zip(specs, mouths)):
        line = next((s for s in stop_lines if s.arm == i), None)
        ext = line.s if line is not None else max([mouth] + [c.s + cfg.crosswalk_width / 2
                                                            for c in crosswalks if c.arm == i])
        left, right = strip(spec, mouth)
        cum = geo.cumulative_length(left)
        k = int(np.searchsorted(cum, ext - mouth))
        up_right = np.vstack([right[:k], geo.point_at(right, ext - mouth)])  # outwards
        down_left = np.vstack([geo.point_at(left, ext - mouth), left[:k][::-1]])  # back in
        area += [*up_right, *down_left, *corners[i][1:-1]]
    return geo.dedupe(np.array(area))


def _place_signals(specs: list[ArmSpec], angles: list[float], stop_lines: list[StopLine], signalled: bool,
                   notes: list[str]) -> tuple[list[SignalHead], list[list[int]]]:
    """A signal head at each stop line and the two-phase plan, when the junction is signalled
    (``signalled``, or any arm found a head); a head no arm found is inferred, with a note."""
    signals: list[SignalHead] = []
    if not (signalled or any(s.signals for s in specs)):
        return signals, []
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
    return signals, [[g] for g in sorted({h.group for h in signals})]


def _spawn_regions(lanes: list[Lane], stop_lines: list[StopLine], mouths: list[float],
                   cfg: ImportConfig) -> list[SpawnRegion]:
    """Where cars may start on each inbound lane: from its outer end to ``spawn_gap`` before its
    stop line."""
    spawns = []
    for lane in lanes:
        if lane.direction == "in":
            line = next(s for s in stop_lines if s.arm == lane.arm)
            length = float(geo.cumulative_length(lane.centreline)[-1])
            hi = length - (line.s - mouths[lane.arm]) - cfg.spawn_gap
            if hi > 0:
                spawns.append(SpawnRegion(lane=lane.id, s_range=(0.0, hi)))
    return spawns


def signal_groups(angles: list[float], lanes_in: list[int], lanes_out: list[int]) -> list[int]:
    """Two-phase plan: the busiest approach and the approaches roughly opposite it (or parallel
    to it) are group 0; the crossing approaches are group 1. ``angles``: outward arm directions."""
    lead = max(range(len(angles)), key=lambda i: (lanes_in[i], lanes_in[i] + lanes_out[i]))
    return [0 if abs(math.cos(angles[i] - angles[lead])) >= math.cos(math.radians(45)) else 1
            for i in range(len(angles))]
