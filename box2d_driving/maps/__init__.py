"""Real junctions: the road-map format and importers (OpenStreetMap, nuScenes map expansion), and
the builder that lays a junction out from a description of its roads (:class:`ArmSpec`)."""

from box2d_driving.maps.arm_spec import ArmSpec
from box2d_driving.maps.build import build_map
from box2d_driving.maps.config import ImportConfig
from box2d_driving.maps.parse import load_map
from box2d_driving.maps.roadmap import MapError, RoadMap

__all__ = ["ArmSpec", "ImportConfig", "MapError", "RoadMap", "build_map", "load_map"]
