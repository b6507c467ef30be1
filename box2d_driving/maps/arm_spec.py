"""How an importer describes one road leaving a junction (:class:`ArmSpec`), and the arm
geometry the layout steps share.

Lateral positions ``u`` are measured to the right of an arm's outward direction. The carriageway
is centred on the axis: inbound lanes to the left of ``split``, outbound lanes to its right.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from typing import Optional

import numpy as np

from box2d_driving.maps import geometry as geo
from box2d_driving.maps.roadmap import MOVEMENTS, MapError


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


def checked_spec(spec: ArmSpec, index: int) -> ArmSpec:
    """``spec`` as the builder needs it, its centre line as a float array; :class:`MapError` naming
    the arm (``index`` or name) and the field when a value cannot describe a road: a centre line
    that is not two or more finite ``(x, y)`` points, lane counts that are not non-negative
    integers (or both zero), a lane width that is not a positive number, a negative median or
    turn lanes with unknown movements."""
    where = f"arm {spec.name or index!r}"
    try:
        line = np.asarray(spec.centreline, dtype=float)
    except (TypeError, ValueError):
        raise MapError(f"{where}: centreline must be (x, y) points in metres") from None
    if line.ndim != 2 or line.shape[1] != 2 or len(line) < 2 or not np.isfinite(line).all():
        raise MapError(f"{where}: centreline must be two or more finite (x, y) points, got shape {line.shape}")
    for name in ("lanes_in", "lanes_out"):
        value = getattr(spec, name)
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 0:
            raise MapError(f"{where}: {name} must be a non-negative integer, got {value!r}")
    if spec.lanes_in + spec.lanes_out == 0:
        raise MapError(f"{where}: it has no lanes (lanes_in and lanes_out both 0)")
    if not _finite(spec.lane_width) or spec.lane_width <= 0:
        raise MapError(f"{where}: lane_width must be a positive number of metres, got {spec.lane_width!r}")
    if not _finite(spec.median) or spec.median < 0:
        raise MapError(f"{where}: median must be a non-negative number of metres, got {spec.median!r}")
    if spec.turn_lanes is not None and not all(isinstance(t, (set, frozenset)) and t <= set(MOVEMENTS)
                                               for t in spec.turn_lanes):
        raise MapError(f"{where}: turn_lanes must be, per inbound lane, a set of {MOVEMENTS}")
    return replace(spec, centreline=line)


def _finite(value: object) -> bool:
    """A finite real number (not a bool)."""
    return isinstance(value, (int, float, np.number)) and not isinstance(value, bool) and math.isfinite(value)


def arm_angle(centreline: np.ndarray, at: float = 15.0) -> float:
    """Outward direction of an arm: from the centre to the point ``at`` metres out (rad)."""
    p = geo.point_at(centreline, at) - centreline[0]
    return math.atan2(p[1], p[0])


def strip(spec: ArmSpec, start: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
    """Left and right edges of the arm's carriageway from arc length ``start`` outwards."""
    axis = geo.resample(spec.centreline, 1.0, start)
    return geo.offset(axis, spec.u_left), geo.offset(axis, spec.u_right)
