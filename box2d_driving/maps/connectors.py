"""Connectors: the paths a car may take through the junction, from each inbound lane to the
outbound lanes its turn lanes allow, and which of them conflict."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from box2d_driving.maps import geometry as geo
from box2d_driving.maps.arm_spec import ArmSpec
from box2d_driving.maps.config import ImportConfig
from box2d_driving.maps.mirror import swap_turn
from box2d_driving.maps.roadmap import Arm, Connector, Lane


@dataclass
class TurnNaming:
    """How notes name lanes and turns: as they are in reality, also when the junction was laid out
    as the mirror image of a left-hand one (``mirrored``)."""

    specs: list[ArmSpec]
    mirrored: bool

    def lane(self, lane: Lane) -> int:
        spec = self.specs[lane.arm]
        count = spec.lanes_in if lane.direction == "in" else spec.lanes_out
        return count - 1 - lane.index if self.mirrored else lane.index

    def turn(self, movement: str) -> str:
        return swap_turn(movement) if self.mirrored else movement


def connect_lanes(specs: list[ArmSpec], angles: list[float], arms: list[Arm], lanes: list[Lane],
                  on_road: Callable[[np.ndarray], np.ndarray], cfg: ImportConfig, naming: TurnNaming,
                  notes: list[str]) -> list[Connector]:
    """Connectors from each inbound lane to the outbound lanes its turn lanes allow (Bezier curves;
    tighter than ``cfg.min_turn_radius`` or leaving the road (``on_road``: per point of a path) are
    left out with a note), with their conflicts marked. ``angles``: each arm's outward direction
    (rad)."""
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
                movement = classify_turn(_wrap(angles[j] - _wrap(angles[i] + math.pi)), cfg)
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
                label = (f"{naming.turn(movement)} from {spec.name!r} lane {naming.lane(lanes[fl])} "
                         f"to {specs[j].name!r} lane {naming.lane(lanes[tl])}")
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
            notes.append(f"inbound lane {naming.lane(lane)} of {specs[lane.arm].name!r} has no connector")
    return connectors


def mark_conflicts(connectors: list[Connector]) -> None:
    """Connectors from different lanes conflict if their paths cross or they end on one lane."""
    for c in connectors:
        c.conflicts = [d.id for d in connectors if d.from_lane != c.from_lane
                       and (d.to_lane == c.to_lane or geo.polylines_cross(c.path, d.path))]


def _wrap(a: float) -> float:
    """Angle ``a`` (rad) in [-pi, pi)."""
    return (a + math.pi) % (2 * math.pi) - math.pi


def classify_turn(turn: float, cfg: ImportConfig) -> str:
    """The movement a turn of ``turn`` (rad, left positive, within +-pi) makes: straight, left,
    right or uturn, by ``cfg.straight_angle`` and ``cfg.uturn_angle``."""
    if abs(turn) < cfg.straight_angle:
        return "straight"
    if abs(turn) > cfg.uturn_angle:
        return "uturn"
    return "left" if turn > 0 else "right"


def _default_turns(n: int) -> list[set[str]]:
    """Movements per inbound lane (left to right) where the data gives none: a single lane serves
    every movement; else the leftmost lane turns left or goes straight, the rightmost turns right
    or goes straight, those between go straight."""
    if n == 1:
        return [{"left", "straight", "right"}]
    return [{"left", "straight"}] + [{"straight"}] * (n - 2) + [{"straight", "right"}]
