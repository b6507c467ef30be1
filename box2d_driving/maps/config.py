"""Numbers the map importers use (metres, radians), in one typed, validated place."""

from __future__ import annotations

import math
from dataclasses import dataclass, field

from box2d_driving.maps.roadmap import MapError

# Lanes per direction when a road has no usable lane tags: (two-way road, one-way road).
DEFAULT_LANES: dict[str, tuple[int, int]] = {
    "motorway": (2, 2), "trunk": (2, 2), "primary": (1, 2), "secondary": (1, 2), "tertiary": (1, 1),
    "unclassified": (1, 1), "residential": (1, 1), "living_street": (1, 1),
    "motorway_link": (1, 1), "trunk_link": (1, 1), "primary_link": (1, 1),
    "secondary_link": (1, 1), "tertiary_link": (1, 1),
}


@dataclass(frozen=True)
class ImportConfig:
    """How a junction is cut out of source data and turned into a :class:`RoadMap`.

    Attributes:
        drive_on: the side traffic keeps to, ``"right"`` (Helsinki) or ``"left"`` (UK, Japan,
            Singapore, ...).
        size_m: side of the square around the junction centre that the map covers (m).
        min_arm_length: an arm cut shorter than this (extract edge, dead end) is an error (m).
        merge_radius: junction nodes this close along the road network are one junction
            (dual carriageways, staggered nodes) (m).
        dual_angle: two one-way roads leaving the junction within this angle of each other, in
            opposite directions, are one dual-carriageway arm (rad).
        dual_separation: ... if their axes are at most this far apart (m).
        lane_width: lane width when the data gives no ``width`` (m).
        lane_width_range: a width derived from ``width / lanes`` is clipped to this (m).
        default_lanes: lanes per direction by road class, (two-way, one-way).
        curb_radius: the carriageway of an arm starts this far beyond the point where it stops
            overlapping its neighbours, leaving room for rounded corners (m).
        corner_samples: points per rounded corner.
        crosswalk_width: crosswalk extent along the road (m).
        crosswalk_reach: crossings further than this beyond an arm's mouth are left out (m).
        stop_margin: gap between a stop line and the crosswalk or the junction area (m).
        signal_radius: a signal node without usable direction belongs to the nearest approach
            within this distance of its stop line (m).
        straight_angle: a movement turning less than this is ``straight`` (rad).
        uturn_angle: a movement turning more than this is a U-turn (left out) (rad).
        connector_handle: Bezier handle length of a connector, as a fraction of its chord.
        min_turn_radius: connectors tighter than this are left out (m).
        edge_clearance: connector paths must stay this far inside the drivable area (m); about
            half a car's width, so that a car following the path does not touch an edge.
        spawn_gap: spawn regions end this far before the stop line (m).
        sample_step: spacing of resampled centre lines (m).
        road_classes: OSM ``highway`` values that carry cars.
    """

    drive_on: str = "right"
    size_m: float = 100.0
    min_arm_length: float = 25.0
    merge_radius: float = 20.0
    dual_angle: float = math.radians(30.0)
    dual_separation: float = 30.0
    lane_width: float = 3.25
    lane_width_range: tuple[float, float] = (2.75, 4.0)
    default_lanes: dict[str, tuple[int, int]] = field(default_factory=lambda: dict(DEFAULT_LANES))
    curb_radius: float = 6.0
    corner_samples: int = 8
    crosswalk_width: float = 3.0
    crosswalk_reach: float = 15.0
    stop_margin: float = 1.0
    signal_radius: float = 30.0
    straight_angle: float = math.radians(35.0)
    uturn_angle: float = math.radians(150.0)
    connector_handle: float = 0.4
    min_turn_radius: float = 3.0
    edge_clearance: float = 1.0
    spawn_gap: float = 3.0
    sample_step: float = 2.0
    road_classes: tuple[str, ...] = tuple(DEFAULT_LANES)

    def __post_init__(self) -> None:
        if self.drive_on not in ("right", "left"):
            raise MapError(f"ImportConfig.drive_on must be 'right' or 'left', got {self.drive_on!r}")
        positive = ("size_m", "min_arm_length", "lane_width", "crosswalk_width", "sample_step",
                    "signal_radius", "min_turn_radius")
        for name in positive:
            if not getattr(self, name) > 0:
                raise MapError(f"ImportConfig.{name} must be positive, got {getattr(self, name)!r}")
        if self.min_arm_length > self.size_m / 2:
            raise MapError("ImportConfig.min_arm_length must not exceed size_m / 2")
        lo, hi = self.lane_width_range
        if not 0 < lo <= self.lane_width <= hi:
            raise MapError("ImportConfig.lane_width_range must contain lane_width")
        if not 0 < self.straight_angle < self.uturn_angle < math.pi:
            raise MapError("need 0 < straight_angle < uturn_angle < pi")
        if self.corner_samples < 2:
            raise MapError("ImportConfig.corner_samples must be >= 2")
