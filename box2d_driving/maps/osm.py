"""Import a real junction from OpenStreetMap data into a :class:`RoadMap`.

``import_junction("Helsinki.osm.pbf", 25345669)`` (or ``(lat, lon)``) cuts a ``size_m`` square
around the junction and returns the map. What real data does and how it is handled:

* roads are split into many short ways: branches are chained through nodes that join only two
  road segments, across way boundaries;
* junctions drawn as several nodes (dual carriageways, staggered nodes) are merged when they are
  within ``merge_radius`` along the roads; two one-way roads leaving in nearly the same direction
  in opposite senses become one dual-carriageway arm;
* a road that ends before the map's edge (extract edge, dead end) is kept, marked ``cut`` and
  noted, if it is at least ``min_arm_length`` long, and refused with a message otherwise; a road
  reaching the next junction stops there;
* lanes come from ``lanes:forward/backward``, ``lanes`` and ``oneway`` (``-1`` too), with
  defaults by road class when missing; lane width from ``width``; ``turn:lanes`` when it matches;
* a signal node belongs to the approach whose way it lies on (``traffic_signals:direction`` or
  ``direction`` picks the travel direction; signals for outbound traffic are left out) or, with
  no usable direction, to the nearest approach within ``signal_radius``; a tagged junction node
  signals every approach;
* crossings are ``highway=crossing`` nodes, nodes with any ``crossing=*``, and footway/cycleway
  crossing ways that cut a road, with or without a ``crossing`` type.
"""

from __future__ import annotations

import math
from collections import defaultdict
from pathlib import Path
from typing import Optional, Sequence, Union

import numpy as np

from box2d_driving.maps import geometry as geo
from box2d_driving.maps.arm_spec import ArmSpec, arm_angle
from box2d_driving.maps.build import build_map
from box2d_driving.maps.config import ImportConfig
from box2d_driving.maps.osm_data import LocalFrame, OsmData, read_osm
from box2d_driving.maps.roadmap import MapError, RoadMap
from box2d_driving.road.geometry import Path as TrackPath

LICENCE = {"licence": "ODbL-1.0", "attribution": "(c) OpenStreetMap contributors",
           "licence_url": "https://opendatacommons.org/licenses/odbl/1-0/"}
_ONEWAY = ("yes", "true", "1")
_TURNS = {"left": "left", "slight_left": "left", "sharp_left": "left", "through": "straight",
          "right": "right", "slight_right": "right", "sharp_right": "right", "merge_to_left": "straight",
          "merge_to_right": "straight", "reverse": "uturn", "none": "straight", "": "straight"}


class _Graph:
    """Road segments around the junction: node -> [(neighbour, way index, along the way?)]."""

    def __init__(self, data: OsmData, frame: LocalFrame) -> None:
        self.data = data
        self.xy: dict[int, np.ndarray] = {}
        self.adj: dict[int, list[tuple[int, int, bool]]] = defaultdict(list)
        for k, way in enumerate(data.roads):
            pts = frame.project(way.coords)
            for ref, p in zip(way.refs, pts):
                if np.all(np.isfinite(p)):
                    self.xy[ref] = p
            for a, b in zip(way.refs[:-1], way.refs[1:]):
                if a != b:
                    self.adj[a].append((b, k, True))
                    self.adj[b].append((a, k, False))

    def degree(self, ref: int) -> int:
        return len({n for n, _, _ in self.adj.get(ref, [])})


def _int_tag(tags: dict[str, str], key: str, notes: list[str], way_id: int) -> Optional[int]:
    if key not in tags:
        return None
    try:
        value = int(tags[key].strip())
        if value < 0:
            raise ValueError
        return value
    except ValueError:
        notes.append(f"way {way_id}: {key}={tags[key]!r} is not a lane count; ignored")
        return None


def lane_counts(tags: dict[str, str], outward_forward: bool, cfg: ImportConfig, notes: list[str],
                way_id: int = 0) -> tuple[int, int]:
    """``(inbound, outbound)`` lanes of a way for traffic towards / away from the junction, when
    the way is traversed outwards along (``outward_forward``) or against its node order."""
    highway = tags.get("highway", "")
    two_way_default, one_way_default = cfg.default_lanes.get(highway, (1, 1))
    oneway = tags.get("oneway", "")
    one_fwd = oneway in _ONEWAY or tags.get("junction") in ("roundabout", "circular") or (
        highway == "motorway" and oneway != "no")
    lanes = _int_tag(tags, "lanes", notes, way_id)
    fwd = _int_tag(tags, "lanes:forward", notes, way_id)
    bwd = _int_tag(tags, "lanes:backward", notes, way_id)
    if one_fwd or oneway == "-1":
        n = lanes or fwd or bwd or one_way_default
        fwd, bwd = (n, 0) if one_fwd else (0, n)
    elif fwd and bwd:
        if lanes and lanes != fwd + bwd:
            notes.append(f"way {way_id}: lanes={lanes} but forward+backward={fwd + bwd}; used the latter")
    elif lanes and fwd:
        bwd = max(lanes - fwd, 1)
    elif lanes and bwd:
        fwd = max(lanes - bwd, 1)
    elif lanes:
        if lanes == 1:
            notes.append(f"way {way_id}: two-way road with lanes=1; one lane each way")
        elif lanes % 2:
            notes.append(f"way {way_id}: lanes={lanes} on a two-way road without lanes:forward/backward; "
                         f"{lanes - lanes // 2} forward")
        fwd, bwd = max(lanes - lanes // 2, 1), max(lanes // 2, 1)
    else:
        fwd = bwd = two_way_default
        notes.append(f"way {way_id}: no lane tags; {two_way_default} lane(s) each way ({highway} default)")
    assert fwd is not None and bwd is not None  # every branch above sets both
    return (bwd, fwd) if outward_forward else (fwd, bwd)


def turn_lanes(tags: dict[str, str], inbound_forward: bool) -> Optional[list[set[str]]]:
    """Allowed movements per inbound lane (left to right) from ``turn:lanes[:forward|:backward]``."""
    value = tags.get("turn:lanes:forward" if inbound_forward else "turn:lanes:backward")
    if value is None and inbound_forward:
        value = tags.get("turn:lanes")
    if not value:
        return None
    return [{_TURNS.get(t.strip(), "straight") for t in lane.split(";")} - {"uturn"} or {"straight"}
            for lane in value.split("|")]


class _Branch:
    """A road leaving the junction: nodes walked outwards and the ways they came from."""

    def __init__(self, start: int) -> None:
        self.nodes = [start]
        self.steps: list[tuple[int, bool]] = []  # (way index, along the way?) per segment
        self.cut = False
        self.end_reason = ""


def _trace(g: _Graph, cluster: set[int], start: int, first: tuple[int, int, bool], centre: np.ndarray,
           cfg: ImportConfig) -> _Branch:
    """Walk from ``start`` along ``first`` until the map edge, the next junction or the data's end."""
    b = _Branch(start)
    prev, (node, way, fwd) = start, first
    while True:
        b.steps.append((way, fwd))
        if node not in g.xy:  # node missing from the extract
            b.cut, b.end_reason = True, "the extract's edge"
            b.steps.pop()
            return b
        b.nodes.append(node)
        if np.max(np.abs(g.xy[node] - centre)) >= cfg.size_m / 2:
            b.end_reason = "the map edge"
            return b
        if node in cluster:
            b.end_reason = "the junction itself"
            return b
        onward = [e for e in g.adj[node] if e[0] != prev]
        if g.degree(node) >= 3:
            b.end_reason = "the next junction"
            return b
        if not onward:
            b.cut, b.end_reason = True, "a dead end or the data's end"
            return b
        prev, (node, way, fwd) = node, onward[0]


def _cluster(g: _Graph, centre_ref: int, cfg: ImportConfig) -> set[int]:
    """Junction nodes within ``merge_radius`` of ``centre_ref`` along the roads."""
    best = {centre_ref: 0.0}
    frontier = [centre_ref]
    while frontier:
        node = frontier.pop()
        for nxt, _, _ in g.adj[node]:
            if nxt not in g.xy:
                continue
            d = best[node] + float(np.linalg.norm(g.xy[nxt] - g.xy[node]))
            if d <= cfg.merge_radius and d < best.get(nxt, math.inf):
                best[nxt] = d
                frontier.append(nxt)
    return {n for n in best if g.degree(n) >= 3}


def _find_centre(g: _Graph, data: OsmData, where: Union[int, tuple[float, float]], frame_for) -> int:
    if isinstance(where, (int, np.integer)):
        ref = int(where)
        if ref not in g.adj:
            raise MapError(f"node {ref} is not on a road that carries cars in {data.path.name}")
        if g.degree(ref) < 3:
            raise MapError(f"node {ref} joins {g.degree(ref)} road segment(s); not a junction")
        return ref
    lat, lon = where
    frame = frame_for(lat, lon)
    here = frame.project(np.array([[lat, lon]]))[0]
    candidates = [(float(np.linalg.norm(frame.project(np.array([ll]))[0] - here)), r)
                  for r in g.adj if g.degree(r) >= 3 for ll in [data.location(r)] if ll is not None]
    if not candidates or min(candidates)[0] > 50.0:
        raise MapError(f"no road junction within 50 m of ({lat}, {lon}) in {data.path.name}")
    return min(candidates)[1]


def import_junction(path: Union[str, Path, OsmData], where: Union[int, tuple[float, float]],
                    cfg: Optional[ImportConfig] = None, name: Optional[str] = None) -> RoadMap:
    """Cut the junction at OSM node ``where`` (or nearest to ``(lat, lon)``) out of an OSM file.

    Raises :class:`MapError` naming the problem (no such node, not a junction, an arm too short, an
    unreadable file, ...). See the module docstring for how real-data quirks are handled.
    """
    try:
        return _import_junction(path, where, cfg, name)
    except MapError:
        raise
    except (IndexError, KeyError, ValueError, TypeError, ZeroDivisionError, FloatingPointError) as exc:
        # data the checks along the way do not foresee: still one MapError naming the file
        file = path.path if isinstance(path, OsmData) else path
        raise MapError(f"{file}: cannot import the junction at {where!r}: malformed data "
                       f"({type(exc).__name__}: {exc})") from None


def _import_junction(path: Union[str, Path, OsmData], where: Union[int, tuple[float, float]],
                     cfg: Optional[ImportConfig], name: Optional[str]) -> RoadMap:
    cfg = cfg or ImportConfig()
    data = path if isinstance(path, OsmData) else read_osm(path, cfg.road_classes)
    if not isinstance(where, (int, np.integer)):
        try:
            where = (float(where[0]), float(where[1]))
        except (TypeError, ValueError, IndexError):
            raise MapError(f"junction must be an OSM node id or (lat, lon), got {where!r}") from None
        if not (-90.0 <= where[0] <= 90.0 and -180.0 <= where[1] <= 180.0):  # NaN fails too
            raise MapError(f"junction position {where!r} is not a latitude in [-90, 90] and a longitude "
                           f"in [-180, 180] (degrees)")
    probe = LocalFrame(*(data.location(int(where)) or (0.0, 0.0))) if isinstance(where, (int, np.integer)) \
        else LocalFrame(*where)
    g = _Graph(data, probe)
    centre_ref = _find_centre(g, data, where, LocalFrame)
    found = data.location(centre_ref)
    if found is None:  # _find_centre picks a node on a road: a file read twice differently
        raise MapError(f"junction node {centre_ref} has no location on a road in {data.path.name}")
    lat0, lon0 = found
    frame = LocalFrame(lat0, lon0)
    g = _Graph(data, frame)
    cluster = _cluster(g, centre_ref, cfg)
    centre = np.mean([g.xy[n] for n in cluster], axis=0)
    notes = list(data.notes)
    if len(cluster) > 1:
        notes.append(f"junction nodes {sorted(cluster)} merged into one junction")

    branches = []
    for c in sorted(cluster):
        for edge in g.adj[c]:
            b = _trace(g, cluster, c, edge, centre, cfg)
            if b.nodes[-1] in cluster and b.end_reason == "the junction itself":
                continue  # a road between two nodes of the merged junction
            branches.append(b)
    arms = [(s, [b]) for b in branches for s in [_spec(g, b, centre, cfg, notes)] if s is not None]
    arms = _merge_dual(arms, cfg, notes)
    specs = [s for s, _ in arms]
    for s in specs:  # every axis starts at the junction centre (merged junctions: their mean)
        if np.linalg.norm(s.centreline[0] - centre) > 1e-6:
            s.centreline = np.vstack([centre, s.centreline])
    _attach_signals_and_crossings(g, data, frame, arms, cluster, centre, cfg)
    signalled = any(data.nodes.get(n, (0, 0, {}))[2].get("highway") == "traffic_signals" for n in cluster)
    for s in specs:
        s.centreline = s.centreline - centre
    source = {"kind": "openstreetmap", "file": data.path.name, "node": int(centre_ref),
              "junction_nodes": sorted(int(n) for n in cluster), "centre_latlon": [lat0, lon0],
              "streets": sorted({s.name for s in specs if s.name}), **LICENCE}
    stem = data.path.name.split(".")[0].lower()
    roadmap = build_map(specs, cfg, name or f"{stem}_{centre_ref}", source, signalled=signalled, notes=notes)
    if not roadmap.connectors:  # every arm one-way in, or every one out: nothing can cross it
        listed = ", ".join(f"{a.name or a.id}: {len(a.lanes_in)} in/{len(a.lanes_out)} out" for a in roadmap.arms)
        raise MapError(f"the junction at node {centre_ref} has no way through: no inbound lane connects to an "
                       f"outbound one (arms: {listed})")
    return roadmap


def _spec(g: _Graph, b: _Branch, centre: np.ndarray, cfg: ImportConfig, notes: list[str]) -> Optional[ArmSpec]:
    way_idx, fwd = b.steps[0]
    way = g.data.roads[way_idx]
    points = np.vstack([g.xy[n] for n in b.nodes]) if len(b.nodes) > 1 else None
    label = f"road {way.tags.get('name', way.id)!r} (way {way.id})"
    if points is None:
        raise MapError(f"{label} leaves the junction into {b.end_reason} at once; cannot lay it out")
    points = geo.dedupe(points)
    length = float(geo.cumulative_length(points)[-1])
    if length > cfg.size_m / 2:  # trim to the map's edge
        points = geo.resample(points, cfg.sample_step / 4, 0.0, cfg.size_m / 2)
        length = cfg.size_m / 2
    if length < cfg.min_arm_length:
        raise MapError(f"{label} ends after {length:.0f} m at {b.end_reason} (node {b.nodes[-1]}); arms "
                       f"need {cfg.min_arm_length:.0f} m: pick a junction further from the data's edge "
                       f"or lower min_arm_length")
    if b.cut or length < cfg.size_m / 2 - 1e-6:
        notes.append(f"{label} ends after {length:.0f} m at {b.end_reason}")
    n_in, n_out = lane_counts(way.tags, fwd, cfg, notes, way.id)
    if n_in + n_out == 0:
        return None
    width = cfg.lane_width
    if "width" in way.tags:
        try:
            width = float(way.tags["width"].split()[0]) / (n_in + n_out)
            width = float(np.clip(width, *cfg.lane_width_range))
        except ValueError:
            notes.append(f"way {way.id}: width={way.tags['width']!r} unreadable; {cfg.lane_width} m lanes")
    return ArmSpec(centreline=points, lanes_in=n_in, lanes_out=n_out, lane_width=width,
                   name=way.tags.get("name", ""), highway=way.tags.get("highway", ""),
                   turn_lanes=turn_lanes(way.tags, inbound_forward=not fwd) if n_in else None,
                   cut=b.cut, source_ids=sorted({g.data.roads[k].id for k, _ in b.steps}))


def _merge_dual(arms: list[tuple[ArmSpec, list[_Branch]]], cfg: ImportConfig,
                notes: list[str]) -> list[tuple[ArmSpec, list[_Branch]]]:
    """One arm from an inbound-only and an outbound-only road leaving side by side."""
    specs = [s for s, _ in arms]
    out, used = [], set()
    for i, a in enumerate(specs):
        if i in used:
            continue
        partner = None
        if a.lanes_out == 0 or a.lanes_in == 0:
            for j in range(i + 1, len(specs)):
                b = specs[j]
                if j in used or (a.lanes_in == 0) == (b.lanes_in == 0) or b.lanes_in * b.lanes_out:
                    continue
                gap = abs(math.remainder(arm_angle(a.centreline) - arm_angle(b.centreline), 2 * math.pi))
                sep = float(np.linalg.norm(geo.point_at(a.centreline, 20.0) - geo.point_at(b.centreline, 20.0)))
                if gap < cfg.dual_angle and sep < cfg.dual_separation:
                    partner = j
                    break
        if partner is None:
            out.append(arms[i])
            continue
        b = specs[partner]
        used.add(partner)
        inb, outb = (a, b) if a.lanes_in else (b, a)
        n = int(min(inb.length, outb.length) / 1.0)
        s = np.linspace(0.0, min(inb.length, outb.length), n + 1)
        axis = 0.5 * (geo.point_at(inb.centreline, s) + geo.point_at(outb.centreline, s))
        apart = geo.point_at(inb.centreline, s) - geo.point_at(outb.centreline, s)
        sep = float(np.median(np.linalg.norm(apart, axis=1)))
        median = max(sep - (inb.lanes_in + outb.lanes_out) * inb.lane_width / 2, 0.0)
        notes.append(f"dual carriageway {inb.name or outb.name!r}: one arm, median {median:.1f} m")
        merged = ArmSpec(centreline=axis, lanes_in=inb.lanes_in, lanes_out=outb.lanes_out,
                         lane_width=inb.lane_width, name=inb.name or outb.name, highway=inb.highway,
                         median=median, turn_lanes=inb.turn_lanes, cut=inb.cut or outb.cut,
                         source_ids=sorted(set(inb.source_ids) | set(outb.source_ids)))
        out.append((merged, arms[i][1] + arms[partner][1]))
    return out


def _attach_signals_and_crossings(g: _Graph, data: OsmData, frame: LocalFrame,
                                  arms: list[tuple[ArmSpec, list[_Branch]]], cluster: set[int],
                                  centre: np.ndarray, cfg: ImportConfig) -> None:
    """Give each arm the signal nodes and crossings that belong to it (arm axes still absolute)."""
    specs = [s for s, _ in arms]
    on_way: dict[int, tuple[int, bool]] = {}  # node -> (arm index, outward along its way?)
    for k, (_, branches) in enumerate(arms):
        for b in branches:
            for node, (_, fwd) in zip(b.nodes[1:], b.steps):
                on_way[node] = (k, fwd)

    def along(spec: ArmSpec, p: np.ndarray) -> tuple[float, float]:
        """Arc length of the closest axis point to ``p`` and the distance to it (m)."""
        path = TrackPath.from_points(spec.centreline)
        s = path.project(p)
        return s, float(np.linalg.norm(path.pose(s)[0] - p))

    for ref, (lat, lon, tags) in data.nodes.items():
        if ref in cluster:
            continue
        p = frame.project(np.array([lat, lon]))
        if np.max(np.abs(p - centre)) > cfg.size_m / 2:
            continue
        if tags.get("highway") == "traffic_signals":
            direction = tags.get("traffic_signals:direction", tags.get("direction", ""))
            if ref in on_way and direction in ("forward", "backward"):
                k, outward_forward = on_way[ref]
                if (direction == "forward") == outward_forward:
                    continue  # controls traffic leaving this junction
                candidates: Sequence[int] = [k]
            else:
                candidates = range(len(specs))
            best = min(((along(specs[k], p)[::-1], k) for k in candidates if specs[k].lanes_in), default=None)
            if best is not None:  # the nearest inbound axis
                (lateral, s), k = best
                if s <= cfg.signal_radius + specs[k].width and lateral <= specs[k].width / 2 + 5.0:
                    specs[k].signals.append((p, ref))
        elif ref in on_way:
            k = on_way[ref][0]
            specs[k].crossings.append((along(specs[k], p)[0], tags.get("crossing", "unknown"), ref))
    for way in data.crossing_ways:
        pts = frame.project(way.coords)
        if not np.all(np.isfinite(pts)) or len(pts) < 2:
            continue
        for k, spec in enumerate(specs):
            axis = spec.centreline
            hits = geo.segments_intersect(pts[:-1], pts[1:], axis[:-1], axis[1:])
            if hits.any():
                _, j = np.argwhere(hits)[0]
                s = float(geo.cumulative_length(axis)[j])
                if not any(abs(s - c[0]) < cfg.crosswalk_width for c in spec.crossings):
                    spec.crossings.append((s, way.tags.get("crossing", "unknown"), way.id))
