"""Mirror images of maps: left-hand traffic is right-hand traffic seen in a mirror.

Reflecting a junction across the x axis (``y -> -y``) turns a layout for traffic keeping right
into one for traffic keeping left, and turns every left turn into a right turn. The builder lays
out a left-hand junction by mirroring its arms, building as for right-hand traffic and mirroring
the map back with :func:`mirror_map`.
"""

from __future__ import annotations

import dataclasses

import numpy as np

from box2d_driving.maps.roadmap import RoadMap

FLIP_Y = np.array([1.0, -1.0])
SWAPPED_TURNS = {"left": "right", "right": "left"}


def swap_turn(movement: str) -> str:
    """The movement seen in a mirror (left <-> right; straight, U-turn unchanged)."""
    return SWAPPED_TURNS.get(movement, movement)


def mirror_map(m: RoadMap) -> RoadMap:
    """``m`` reflected across the x axis: geometry ``y -> -y``, connector movements left <->
    right, and lane indices renumbered so that 0 is again the leftmost lane in its direction."""
    arms = [dataclasses.replace(a, centreline=a.centreline * FLIP_Y, lanes_in=a.lanes_in[::-1],
                                lanes_out=a.lanes_out[::-1]) for a in m.arms]
    index = {}
    for a in arms:  # the mirror's leftmost lane is the original's rightmost
        for ids in (a.lanes_in, a.lanes_out):
            index.update({lane: k for k, lane in enumerate(ids)})
    lanes = [dataclasses.replace(la, centreline=la.centreline * FLIP_Y, index=index[la.id]) for la in m.lanes]
    connectors = [dataclasses.replace(c, path=c.path * FLIP_Y, movement=swap_turn(c.movement),
                                      conflicts=list(c.conflicts)) for c in m.connectors]
    return dataclasses.replace(
        m, arms=arms, lanes=lanes, connectors=connectors,
        stop_lines=[dataclasses.replace(s, segment=s.segment * FLIP_Y) for s in m.stop_lines],
        signals=[dataclasses.replace(h, position=h.position * FLIP_Y) for h in m.signals],
        crosswalks=[dataclasses.replace(c, polygon=c.polygon * FLIP_Y) for c in m.crosswalks],
        drivable=[p * FLIP_Y for p in m.drivable], edges=[e * FLIP_Y for e in m.edges],
        junction_area=m.junction_area * FLIP_Y, spawn_regions=list(m.spawn_regions),
        phases=[list(p) for p in m.phases], notes=list(m.notes), source=dict(m.source))
