"""The project's road-map format: one real junction in a local metric frame, as JSON.

A :class:`RoadMap` holds what a scenario needs to drive cars through a real junction: the arms
(roads leaving the junction), their lanes with direction and width, connectors through the
junction (movement type, path, conflicting connectors), stop lines, signal heads with their group
and a phase plan, crosswalks, drivable polygons, the road edges cars collide with, and spawn
regions. Coordinates are metres in a local east-north frame centred on the junction. The format is
documented in ``docs/maps.md``; :func:`~box2d_driving.maps.parse.load_map` validates a file and
names what is wrong.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, Optional, Union

import numpy as np

from box2d_driving.config import ConfigError

FORMAT = "box2d-driving-map"
VERSION = 1
MOVEMENTS = ("straight", "left", "right", "uturn")


class MapError(ConfigError):
    """A map file or an import request is invalid; the message names the problem."""



@dataclass
class Arm:
    """A road leaving the junction.

    Attributes:
        id: index in ``RoadMap.arms``.
        name: street name (may be empty).
        highway: road class (OSM ``highway`` value, or the source's equivalent).
        centreline: ``(P, 2)`` road axis from the junction centre outwards (m).
        mouth: arc length along ``centreline`` where the arm's own carriageway starts (m).
        lanes_in / lanes_out: lane ids towards / away from the junction.
        cut: the road was cut short (extract edge or data end), not by ``size_m``.
        source_ids: ids of the source objects (OSM ways, nuScenes lane tokens) it was built from.
    """

    id: int
    name: str
    highway: str
    centreline: np.ndarray
    mouth: float
    lanes_in: list[int]
    lanes_out: list[int]
    cut: bool = False
    source_ids: list[Union[int, str]] = field(default_factory=list)


@dataclass
class Lane:
    """One lane of an arm, ``centreline`` in the driving direction (m).

    ``index`` counts from the leftmost lane in the driving direction (0). For an inbound lane the
    centreline ends at the arm's mouth; an outbound one starts there.
    """

    id: int
    arm: int
    direction: str  # "in" or "out"
    index: int
    width: float
    centreline: np.ndarray


@dataclass
class Connector:
    """A path through the junction from the end of ``from_lane`` to the start of ``to_lane``.

    ``conflicts``: connectors from another lane whose path crosses this one or that end on the same
    lane. ``min_radius``: smallest radius of curvature along ``path`` (m, inf if straight).
    """

    id: int
    from_lane: int
    to_lane: int
    movement: str
    path: np.ndarray
    conflicts: list[int] = field(default_factory=list)
    min_radius: float = float("inf")


@dataclass
class StopLine:
    """Stop line across the inbound lanes of ``arm``: ``segment`` (2, 2) and its arc length
    ``s`` from the junction centre along the arm (m)."""

    arm: int
    s: float
    segment: np.ndarray


@dataclass
class SignalHead:
    """A signal controlling the inbound lanes of ``arm``, in phase group ``group``.

    ``inferred``: no signal node for this approach was found in the data (the junction is
    signalled, so the approach got one).
    """

    id: int
    arm: int
    group: int
    position: np.ndarray
    source_id: Optional[Union[int, str]] = None
    inferred: bool = False


@dataclass
class Crosswalk:
    """A pedestrian crossing over ``arm``: ``polygon`` (4, 2) spanning the carriageway (m);
    ``kind`` is the source's crossing type (``traffic_signals``, ``uncontrolled``, ``unknown``...)."""

    arm: int
    s: float
    polygon: np.ndarray
    kind: str = "unknown"
    source_id: Optional[Union[int, str]] = None


@dataclass
class SpawnRegion:
    """Cars may spawn on ``lane`` with their centre at arc length in ``s_range`` (m)."""

    lane: int
    s_range: tuple[float, float]


@dataclass
class RoadMap:
    """One junction. See the module docstring and ``docs/maps.md``.

    Attributes:
        name: short identifier (e.g. ``helsinki_25345669``).
        source: where the data came from: kind, file, ids, centre, licence, attribution.
        size_m: side of the square the map was cut to (m).
        phases: the signal plan: phase k makes the groups in ``phases[k]`` green.
        drivable: drivable polygons (junction area and each arm's carriageway).
        edges: road-edge polylines cars collide with.
        junction_area: polygon of the junction out to the stop lines (or past the crosswalks of
            outbound-only arms): a car is "in the junction" inside it (right-of-way timing,
            light seen before entering).
        notes: what the importer changed or assumed (cut roads, default lane counts, ...).
    """

    name: str
    source: dict
    size_m: float
    arms: list[Arm]
    lanes: list[Lane]
    connectors: list[Connector]
    stop_lines: list[StopLine]
    signals: list[SignalHead]
    phases: list[list[int]]
    crosswalks: list[Crosswalk]
    drivable: list[np.ndarray]
    edges: list[np.ndarray]
    spawn_regions: list[SpawnRegion]
    junction_area: np.ndarray = field(default_factory=lambda: np.zeros((0, 2)))
    notes: list[str] = field(default_factory=list)

    # ---- queries -------------------------------------------------------------------------------
    @property
    def signalled(self) -> bool:
        return bool(self.signals)

    def connectors_from(self, lane: int) -> list[Connector]:
        return [c for c in self.connectors if c.from_lane == lane]

    def stop_line(self, arm: int) -> Optional[StopLine]:
        return next((s for s in self.stop_lines if s.arm == arm), None)

    def signal_for(self, arm: int) -> Optional[SignalHead]:
        return next((h for h in self.signals if h.arm == arm), None)

    def bounds(self) -> tuple[float, float, float, float]:
        """``(xmin, ymin, xmax, ymax)`` of everything drivable (m)."""
        pts = np.vstack(self.drivable)
        return (float(pts[:, 0].min()), float(pts[:, 1].min()),
                float(pts[:, 0].max()), float(pts[:, 1].max()))

    # ---- JSON ----------------------------------------------------------------------------------
    def to_dict(self) -> dict:
        def clean(obj: Any) -> Any:
            if isinstance(obj, np.ndarray):
                return np.round(obj, 3).tolist()
            if isinstance(obj, dict):
                return {k: clean(v) for k, v in obj.items()}
            if isinstance(obj, (list, tuple)):
                return [clean(v) for v in obj]
            if isinstance(obj, float):
                return obj if np.isfinite(obj) else None
            return obj

        body = {k: getattr(self, k) for k in ("name", "source", "size_m", "phases", "notes")}
        for key in ("arms", "lanes", "connectors", "stop_lines", "signals", "crosswalks", "spawn_regions"):
            body[key] = [asdict(x) for x in getattr(self, key)]
        body["drivable"] = list(self.drivable)
        body["edges"] = list(self.edges)
        body["junction_area"] = self.junction_area
        return clean({"format": FORMAT, "version": VERSION, **body})

    def save(self, path: str | Path, overwrite: bool = False) -> Path:
        """Write the map as JSON; refuses to replace an existing file unless ``overwrite``."""
        path = Path(path)
        if path.exists() and not overwrite:
            raise MapError(f"{path} exists; pass overwrite=True (--overwrite) to replace it")
        path.parent.mkdir(parents=True, exist_ok=True)
        tmp = path.with_suffix(path.suffix + ".tmp")
        try:
            tmp.write_text(json.dumps(self.to_dict(), indent=1))
            tmp.replace(path)
        except BaseException:
            tmp.unlink(missing_ok=True)  # a failed write leaves nothing behind
            raise
        return path
