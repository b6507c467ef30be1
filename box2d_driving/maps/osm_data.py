"""Reading OpenStreetMap data (``.osm.pbf`` or ``.osm`` XML) into plain Python objects.

Only what a junction import needs is kept: ways that carry cars (with their node ids and
coordinates; a node missing from the file, as at an extract's edge, has no coordinates), crossing
ways, and the signal and crossing nodes. Coordinates are projected onto a local tangent plane
(east, north in metres) around a reference point; over a few hundred metres its error is far
below a centimetre.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Optional

import numpy as np

from box2d_driving.maps.roadmap import MapError

EARTH_RADIUS = 6_371_008.8  # mean radius (m)


@dataclass
class OsmWay:
    """A way: ``refs`` node ids; ``coords`` ``(n, 2)`` lat/lon, NaN where the node is missing."""

    id: int
    refs: list[int]
    coords: np.ndarray
    tags: dict[str, str]


@dataclass
class OsmData:
    """Car-carrying ways, footway crossings and tagged nodes of an OSM file."""

    path: Path
    roads: list[OsmWay] = field(default_factory=list)
    crossing_ways: list[OsmWay] = field(default_factory=list)
    nodes: dict[int, tuple[float, float, dict[str, str]]] = field(default_factory=dict)  # lat, lon, tags
    notes: list[str] = field(default_factory=list)  # oddities of the file, passed on to the map's notes

    def location(self, ref: int) -> Optional[tuple[float, float]]:
        """Lat/lon of a node on a road, or None if it is not on one or missing from the file."""
        for way in self.roads:
            if ref in way.refs:
                lat, lon = way.coords[way.refs.index(ref)]
                return None if math.isnan(lat) else (float(lat), float(lon))
        return None


class LocalFrame:
    """Equirectangular projection around ``(lat0, lon0)``: x east, y north (m)."""

    def __init__(self, lat0: float, lon0: float) -> None:
        self.lat0, self.lon0 = lat0, lon0
        self._kx = math.radians(1.0) * EARTH_RADIUS * math.cos(math.radians(lat0))
        self._ky = math.radians(1.0) * EARTH_RADIUS

    def project(self, latlon: np.ndarray) -> np.ndarray:
        latlon = np.asarray(latlon, dtype=np.float64)
        return np.stack([(latlon[..., 1] - self.lon0) * self._kx, (latlon[..., 0] - self.lat0) * self._ky], axis=-1)

    def unproject(self, xy: np.ndarray) -> np.ndarray:
        xy = np.asarray(xy, dtype=np.float64)
        return np.stack([self.lat0 + xy[..., 1] / self._ky, self.lon0 + xy[..., 0] / self._kx], axis=-1)


def _is_crossing_node(tags: dict[str, str]) -> bool:
    return tags.get("highway") == "crossing" or tags.get("crossing", "no") != "no"


def read_osm(path: str | Path, road_classes: tuple[str, ...]) -> OsmData:
    """Read an OSM file with ``osmium`` (:class:`MapError` if it is missing or unreadable)."""
    try:
        import osmium
    except ImportError as exc:  # the [osm] extra: only the importer needs it
        from box2d_driving.plugins import install_hint

        raise MapError(f"reading OSM files needs the 'osmium' package: {install_hint('osm')} "
                       f"(or pip install osmium) ({exc})") from None
    path = Path(path)
    if not path.is_file():
        raise MapError(f"OSM file {path} does not exist")
    data = OsmData(path=path)
    classes = set(road_classes)
    # osmium's location index holds positive ids only; negative ones (new objects in editors'
    # files, valid OSM) are kept here, as are the ids seen twice in a row (a sorted file's duplicates)
    negative: dict[int, tuple[float, float]] = {}
    last = {"id": None}
    duplicated: list[int] = []

    class Handler(osmium.SimpleHandler):
        def node(self, n) -> None:
            if n.id == last["id"]:
                duplicated.append(n.id)
            last["id"] = n.id
            if n.id < 0 and n.location.valid():
                negative[n.id] = (n.location.lat, n.location.lon)
            tags = {t.k: t.v for t in n.tags}
            if tags.get("highway") == "traffic_signals" or _is_crossing_node(tags):
                if not n.location.valid():
                    raise MapError(f"{path}: node {n.id} has an invalid location "
                                   f"(lat/lon out of range or not numbers)")
                data.nodes[n.id] = (n.location.lat, n.location.lon, tags)

        def way(self, w) -> None:
            tags = {t.k: t.v for t in w.tags}
            highway = tags.get("highway")
            is_road = highway in classes and tags.get("area") != "yes"
            is_crossing = tags.get("footway") == "crossing" or tags.get("cycleway") == "crossing"
            if not (is_road or is_crossing):
                return
            refs, coords = [], []
            for n in w.nodes:
                refs.append(n.ref)
                loc = n.location
                coords.append((loc.lat, loc.lon) if loc.valid() else negative.get(n.ref, (math.nan, math.nan)))
            way = OsmWay(w.id, refs, np.array(coords, dtype=np.float64).reshape(-1, 2), tags)
            (data.roads if is_road else data.crossing_ways).append(way)

    try:
        Handler().apply_file(str(path), locations=True)
    except MapError:
        raise
    except Exception as exc:  # osmium's parse errors (e.g. InvalidLocationError) share no base class
        raise MapError(f"{path}: not a readable OSM file ({type(exc).__name__}: {exc})") from None
    if not data.roads:
        raise MapError(f"{path}: no roads that carry cars (highway={', '.join(sorted(classes))})")
    if duplicated:
        shown = ", ".join(map(str, duplicated[:5])) + (", ..." if len(duplicated) > 5 else "")
        data.notes.append(f"{path.name}: {len(duplicated)} node id(s) appear twice ({shown}); the last position of "
                          f"each was used")
    return data
