"""Hand-built OpenStreetMap XML files for the importer tests (coordinates given in metres)."""

from __future__ import annotations

from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from box2d_driving.maps.osm_data import LocalFrame

LAT0, LON0 = 60.0, 25.0


def write_osm(path: Path, nodes: dict[int, tuple[float, float, dict]], ways: dict[int, tuple[list[int], dict]],
              origin: tuple[float, float] = (LAT0, LON0)) -> Path:
    """``nodes``: id -> (x, y, tags) in metres east/north of ``origin`` (lat, lon; degrees);
    ``ways``: id -> (refs, tags). A way may reference a node that is not in ``nodes`` (as at an
    extract's edge)."""
    frame = LocalFrame(*origin)
    lines = ['<?xml version="1.0" encoding="UTF-8"?>', '<osm version="0.6" generator="test">']
    for nid, (x, y, tags) in sorted(nodes.items()):
        lat, lon = frame.unproject(np.array([x, y]))
        body = "".join(f"<tag k={quoteattr(k)} v={quoteattr(v)}/>" for k, v in tags.items())
        lines.append(f'<node id="{nid}" version="1" lat="{lat:.9f}" lon="{lon:.9f}">{body}</node>')
    for wid, (refs, tags) in sorted(ways.items()):
        body = "".join(f'<nd ref="{r}"/>' for r in refs)
        body += "".join(f"<tag k={quoteattr(k)} v={quoteattr(v)}/>" for k, v in tags.items())
        lines.append(f'<way id="{wid}" version="1">{body}</way>')
    lines.append("</osm>")
    path.write_text("\n".join(lines))
    return path


def four_way(path: Path, east_cut: bool = False, origin: tuple[float, float] = (LAT0, LON0)) -> Path:
    """A four-way junction at node 1 (at ``origin``, lat and lon in degrees):

    * east: two-way primary, ``lanes=2``, split into ways 10 (0-20 m) and 11 (20-60 m); with
      ``east_cut`` way 11 ends at node 99, missing from the file (an extract's edge);
    * west: way 12, one-way towards the junction, ``lanes=2``, ``turn:lanes``;
    * north: way 13, residential without lane tags; a signal node (6, no direction) at 14 m and a
      crossing node (7, no ``crossing`` tag) at 8 m;
    * south: way 14, ``oneway=-1`` (towards the junction), ``lanes=1``;
    * a footway crossing way 20 cuts the east road at x = 9 m.
    """
    nodes = {1: (0, 0, {}), 2: (20, 0, {}), 3: (60, 0, {}), 4: (-60, 0, {}), 5: (0, 60, {}),
             6: (0, 14, {"highway": "traffic_signals"}), 7: (0, 8, {"highway": "crossing"}),
             8: (0, -60, {}), 21: (9, 8, {}), 22: (9, -8, {})}
    ways = {
        10: ([1, 2], {"highway": "primary", "lanes": "2", "name": "East"}),
        11: ([2, 99] if east_cut else [2, 3], {"highway": "primary", "lanes": "2", "name": "East"}),
        12: ([4, 1], {"highway": "primary", "lanes": "2", "oneway": "yes", "name": "West",
                      "turn:lanes": "left;through|through;right"}),
        13: ([1, 7, 6, 5], {"highway": "residential", "name": "North"}),
        14: ([1, 8], {"highway": "secondary", "oneway": "-1", "lanes": "1", "name": "South"}),
        20: ([21, 22], {"highway": "footway", "footway": "crossing", "crossing": "uncontrolled"}),
        30: ([21, 5], {"highway": "footway"}),
    }
    if east_cut:
        del nodes[3]
    return write_osm(path, nodes, ways, origin)


def divided(path: Path) -> Path:
    """A two-way street (north-south) crossing a dual carriageway drawn as two one-way ways 10 m
    apart: junction nodes 1 (y = 5) and 2 (y = -5), to be merged into one junction."""
    nodes = {1: (0, 5, {"highway": "traffic_signals"}), 2: (0, -5, {}), 3: (60, 5, {}), 4: (-60, 5, {}),
             5: (60, -5, {}), 6: (-60, -5, {}), 7: (0, 60, {}), 8: (0, -60, {})}
    ways = {
        10: ([3, 1, 4], {"highway": "primary", "oneway": "yes", "lanes": "1", "name": "Avenue"}),  # westbound
        11: ([6, 2, 5], {"highway": "primary", "oneway": "yes", "lanes": "1", "name": "Avenue"}),  # eastbound
        12: ([7, 1, 2, 8], {"highway": "residential", "lanes": "2", "name": "Street"}),
    }
    return write_osm(path, nodes, ways)
