"""Real junctions from map files (``docs/real_junctions.md``; maps: ``docs/maps.md``).

Each episode samples one map from ``config.map`` (shipped map names or JSON files). Every car
starts on an inbound lane (lanes in a random order, round-robin, so cars spread over the
approaches; positions on a lane uniformly random with at least ``spawn_spacing`` between car
centres), picks one of its lane's connectors (straight, left or right) uniformly, and follows the
inbound lane's centre line, the connector and the outbound lane to its end, with acceleration
control. Real signal groups run the two-phase plan (group 0 and group 1 in antiphase, the
lights' timing), so turning traffic meets oncoming traffic and right of way matters. A car is in the
junction inside the map's ``junction_area`` (out to the stop lines, so the light a car saw last
before entering is the one at its stop line). Cars collide with each other and the road edges. The 1-bit turn
signal is the ``communication`` option.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Union

import numpy as np

from box2d_driving.config import ConfigError, DrivingConfig
from box2d_driving.envs.base import DrivingEnv
from box2d_driving.maps import geometry as geo
from box2d_driving.maps.roadmap import MapError, RoadMap
from box2d_driving.maps.shipped import get_map
from box2d_driving.road.geometry import Path
from box2d_driving.road.layout import CarSpawn, LaneAxis, Layout
from box2d_driving.road.lights import sample_lights

DEFAULT_MAPS = ("helsinki_1377211666", "helsinki_25291567", "helsinki_25292451", "helsinki_25345665",
                "helsinki_25345669")


@dataclass(frozen=True)
class RealJunctionConfig(DrivingConfig):
    """Real-junction defaults.

    Attributes:
        map: a shipped map name or a map JSON path, or a tuple of them (one sampled per episode).
        spawn_spacing: least distance between the centres of two cars spawned on one lane (m).
    """

    num_cars: int = 8
    horizon: int = 30
    map: Union[str, tuple[str, ...]] = DEFAULT_MAPS
    spawn_spacing: float = 7.0

    def __post_init__(self) -> None:
        if isinstance(self.map, (list, tuple)):
            object.__setattr__(self, "map", tuple(self.map))
        super().__post_init__()

    def map_names(self) -> tuple[str, ...]:
        return (self.map,) if isinstance(self.map, str) else self.map

    def roadmaps(self) -> list[RoadMap]:
        names = self.map_names()
        if not names or not all(isinstance(n, str) for n in names):
            raise ConfigError(f"map must be a map name or path, or a non-empty tuple of them, got {self.map!r}")
        try:
            maps = [get_map(n) for n in names]
        except MapError as exc:
            raise MapError(f"map: {exc}") from None
        for name, m in zip(names, maps):
            if not m.spawn_regions or not m.connectors:
                raise ConfigError(f"map {name!r} has no spawn regions or no connectors")
            if any(h.group > 1 for h in m.signals):
                raise ConfigError(f"map {name!r}: only two antiphase signal groups (0, 1) are supported")
        return maps

    def slots(self, s_range: tuple[float, float]) -> int:
        """Cars that fit on one spawn region at ``spawn_spacing``."""
        lo, hi = _spawn_range(self, s_range)
        return int((hi - lo) // self.spawn_spacing) + 1 if hi >= lo else 0

    def capacity(self, roadmap: RoadMap) -> int:
        """Cars that fit on the map's spawn regions at ``spawn_spacing``."""
        return sum(self.slots(region.s_range) for region in roadmap.spawn_regions)

    _SLOTS_SET_BY = "the smallest map's spawn regions at spawn_spacing"

    def max_cars(self) -> int:
        if self.spawn_spacing <= self.car_length:
            raise ConfigError(f"spawn_spacing must exceed car_length ({self.car_length}), got {self.spawn_spacing}")
        return min(self.capacity(m) for m in self.roadmaps())


def _spawn_range(cfg: RealJunctionConfig, s_range: tuple[float, float]) -> tuple[float, float]:
    """Where a car's centre may start: the region shrunk by half a car at both ends."""
    return s_range[0] + cfg.car_length / 2, s_range[1] - cfg.car_length / 2


class RealJunctionEnv(DrivingEnv):
    """Cars through a real signalled junction on lane centre lines and connectors."""

    config_class = RealJunctionConfig
    config: RealJunctionConfig  # an instance of config_class
    metadata = {**DrivingEnv.metadata, "name": "real_junction_v0"}

    @property
    def n_lights(self) -> int:  # state() has one slot per signal head of the largest map
        return max(len(m.signals) for m in self.config.roadmaps())

    def build_layout(self, rng: np.random.Generator) -> Layout:
        cfg = self.config
        maps = cfg.roadmaps()
        m = maps[int(rng.integers(len(maps)))] if len(maps) > 1 else maps[0]
        heads = {h.arm: k for k, h in enumerate(m.signals)}
        lights = None
        if m.signals:
            dirs = []
            for h in m.signals:
                lane = m.lanes[m.arms[h.arm].lanes_in[0]].centreline
                dirs.append((lane[-1] - lane[-2]) / np.linalg.norm(lane[-1] - lane[-2]))
            lights = sample_lights(rng, np.array([h.position for h in m.signals]), np.array(dirs),
                                   np.array([h.group for h in m.signals]) % 2, cfg.light_period_range,
                                   cfg.light_yellow, cfg.light_start, cfg.light_period_step,
                                   cfg.light_first_green)

        # lanes in a random order, round-robin; positions on each lane without overlap
        regions = [m.spawn_regions[k] for k in rng.permutation(len(m.spawn_regions))]
        counts = np.zeros(len(regions), dtype=np.int64)
        caps = [cfg.slots(r.s_range) for r in regions]
        k = 0
        for _ in range(cfg.num_cars):
            while counts[k % len(regions)] >= caps[k % len(regions)]:
                k += 1
            counts[k % len(regions)] += 1
            k += 1
        cars = []
        for region, n in zip(regions, counts):
            if n == 0:
                continue
            lo, hi = _spawn_range(cfg, region.s_range)
            slack = (hi - lo) - (n - 1) * cfg.spawn_spacing
            starts = lo + np.sort(rng.uniform(0.0, slack, size=n)) + cfg.spawn_spacing * np.arange(n)
            lane = m.lanes[region.lane]
            options = m.connectors_from(lane.id)
            arm = m.arms[lane.arm]
            mouth_dir = -geo.tangent_at(arm.centreline, arm.mouth)
            for s in starts:
                conn = options[int(rng.integers(len(options)))]
                cars.append(CarSpawn(path=_route(lane.centreline, s, conn.path, m.lanes[conn.to_lane].centreline),
                                     light_index=heads.get(lane.arm, -1), rating=1.0,
                                     lane_axis=LaneAxis(arm.centreline[0].copy(), mouth_dir,
                                                        0.5 * lane.width * (len(arm.lanes_in) + len(arm.lanes_out))),
                                     approach=lane.arm))
        order = rng.permutation(len(cars))  # agent i is not tied to a lane
        edges = np.concatenate([np.stack([e[:-1], e[1:]], axis=1) for e in m.edges])
        return Layout(edges=edges, cars=[cars[i] for i in order], lights=lights, drivable=list(m.drivable),
                      stop_lines=np.array([s.segment for s in m.stop_lines]).reshape(-1, 2, 2),
                      junction_polygon=m.junction_area, crosswalks=[c.polygon for c in m.crosswalks], name=m.name)


def _route(inbound: np.ndarray, start: float, connector: np.ndarray, outbound: np.ndarray) -> Path:
    """Inbound lane from arc length ``start``, the connector, then the whole outbound lane."""
    cum = geo.cumulative_length(inbound)
    rest = inbound[cum > start + 1e-6]
    first = geo.point_at(inbound, start)
    points = np.vstack([first, rest, connector[1:], outbound[1:]])
    return Path.from_points(geo.dedupe(points))
