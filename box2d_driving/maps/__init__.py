"""Real junctions: the road-map format and importers (OpenStreetMap, nuScenes map expansion)."""

from box2d_driving.maps.config import ImportConfig
from box2d_driving.maps.parse import load_map
from box2d_driving.maps.roadmap import MapError, RoadMap

__all__ = ["ImportConfig", "MapError", "RoadMap", "load_map"]
