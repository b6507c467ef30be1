"""Real junctions: the road-map format and importers (OpenStreetMap, nuScenes map expansion)."""

from box2d_driving.maps.config import ImportConfig
from box2d_driving.maps.roadmap import MapError, RoadMap, load_map

__all__ = ["ImportConfig", "MapError", "RoadMap", "load_map"]
