"""The parameter-shared multi-agent driving env: orchestrates world, sensors, reward, lights.

A scenario subclasses :class:`DrivingEnv` and supplies only its config class, its layout generator
(map + spawns, drawn from the env's ``np_random``) and its sat-nav extras.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, Optional

import numpy as np
from gymnasium import logger as gymnasium_logger
from gymnasium import spaces
from gymnasium.utils import EzPickle, seeding
from pettingzoo import ParallelEnv

from box2d_driving.config import ConfigError, DrivingConfig
from box2d_driving.envs import core
from box2d_driving.envs.actions import ActionError, check_actions  # noqa: F401  (ActionError: part of this module's API)
from box2d_driving.envs.observation import FrameHistory, ObservationLayout
from box2d_driving.physics.world import ACTIVE, COLLIDED, DrivingWorld
from box2d_driving.road.geometry import wrap_angle
from box2d_driving.road.layout import Layout
from box2d_driving.road.lights import NO_LIGHT
from box2d_driving.sensors import lidar, readout

if TYPE_CHECKING:
    from box2d_driving.render.scene import Scene
    from box2d_driving.render.viewer import Viewer

# Per-car entries of state(): x, y, cos(h), sin(h), speed, acceleration, goal x, goal y,
# remaining / initial path length, active, arrived, collided, rating.
STATE_FIELDS = ("x", "y", "cos_heading", "sin_heading", "speed", "acceleration", "goal_x",
                "goal_y", "remaining_fraction", "active", "arrived", "collided", "rating")


def check_reset_arguments(seed: Any, options: Any) -> tuple[Optional[int], dict]:
    """``reset``'s ``seed`` as a Python int (numpy integers accepted; ``True`` is not a seed) and
    its ``options`` as a dict; :class:`ConfigError` naming the bad one."""
    if seed is not None:
        if isinstance(seed, (bool, np.bool_)) or not isinstance(seed, (int, np.integer)):
            raise ConfigError(f"reset: seed must be a whole number >= 0 or None, got {seed!r}")
        if seed < 0:
            raise ConfigError(f"reset: seed must be >= 0, got {seed}")
        seed = int(seed)
    if options is not None and not isinstance(options, dict):
        raise ConfigError(f"reset: options must be a dict or None, got {type(options).__name__}")
    return seed, dict(options or {})


class DrivingEnv(ParallelEnv, EzPickle):
    """Cars on fixed tracks with discrete longitudinal accelerations.

    Agents are ``"car_0" .. "car_{N-1}"``; all share one action space (``Discrete``: acceleration
    index, or ``acceleration index + n_accelerations * bit`` with communication) and one
    observation space (see :class:`ObservationLayout`, exposed as :attr:`observation_layout`).
    """

    config_class: type[DrivingConfig] = DrivingConfig
    config: DrivingConfig  # an instance of config_class
    # each scenario-specific sat-nav value's (low, high) bounds (the names: ``satnav_extras``)
    satnav_bounds: dict[str, tuple[float, float]] = {}
    # scenario-specific reward terms (``reward_extra_values``), added after the shipped ones
    reward_extras: tuple[str, ...] = ()
    metadata: dict[str, Any] = {"name": "driving", "render_modes": ["human", "rgb_array"],
                                "is_parallelizable": True, "render_fps": 4}

    def __init__(self, **overrides: Any) -> None:
        EzPickle.__init__(self, **overrides)
        self.config = self.config_class.from_overrides(**overrides)
        cfg = self.config
        self.render_mode = cfg.render_mode
        self.possible_agents = [f"car_{i}" for i in range(cfg.num_cars)]
        self.agents: list[str] = []
        self._index = {a: i for i, a in enumerate(self.possible_agents)}
        fields = ("light", "speed", "heading_error", "inv_goal_distance") + self.satnav_extras
        if cfg.communication:
            fields = fields + ("bit_received",)
        self.observation_layout = ObservationLayout(cfg.history, cfg.n_rays, fields)
        self._obs_space = self._make_observation_space()
        self._act_space = spaces.Discrete(cfg.n_actions)
        self.observation_spaces = {a: self._obs_space for a in self.possible_agents}
        self.action_spaces = {a: self._act_space for a in self.possible_agents}
        n_state = cfg.num_cars * len(STATE_FIELDS) + self.n_lights + 1
        self.state_space = spaces.Box(-np.inf, np.inf, shape=(n_state,), dtype=np.float32)
        self._levels = np.asarray(cfg.accelerations, dtype=np.float64)
        self._accel_range = float(self._levels[-1] - self._levels[0])
        self._backend = "numba" if cfg.lidar_backend == "auto" else cfg.lidar_backend
        self.world = DrivingWorld(cfg)
        # ray directions kept between decisions (the env core keeps them on the first instance it steps)
        self._ray_directions: Optional[lidar.RayDirections] = None
        self.np_random: Optional[np.random.Generator] = None
        self.layout: Optional[Layout] = None
        self._viewer: Optional[Viewer] = None
        # whether scenario_info adds anything (the env core skips merging the base class's empty dicts)
        self.adds_scenario_info = type(self).scenario_info is not DrivingEnv.scenario_info
        self._last_rays: Optional[np.ndarray] = None  # kept while rendering, for drawing the rays
        self._last_dropped: Optional[np.ndarray] = None

    @property
    def satnav_extras(self) -> tuple[str, ...]:
        """Names of the scenario's own sat-nav values (:meth:`satnav_extra_values`), none here; a
        scenario sets the class attribute (``satnav_extras = ("rating",)``) or overrides this."""
        return ()

    @property
    def n_lights(self) -> int:
        """Light slots in :meth:`state` (none here; a scenario with lights sets the count)."""
        return 0

    @property
    def sees_light_from_axis(self) -> bool:
        """Whether a car sees its light from a straight line to the point on its arm's axis at the
        junction (the paper's code; ``light_view="axis_point"``, an intersection option) rather
        than along its approach to the stop line."""
        return getattr(self.config, "light_view", "stop_line") == "axis_point"

    # -- spaces -------------------------------------------------------------------------------
    def observation_space(self, agent: str) -> spaces.Box:
        return self._obs_space

    def action_space(self, agent: str) -> spaces.Discrete:
        return self._act_space

    def _make_observation_space(self) -> spaces.Box:
        lay = self.observation_layout
        bounds = {
            "light": (0.0, 1.0), "speed": (-1.0 if self.config.reverse else 0.0, 1.0),
            "heading_error": (-math.pi, math.pi), "inv_goal_distance": (0.0, 1.0), "bit_received": (0.0, 1.0),
            **self.satnav_bounds,
        }
        unbounded = [f for f in lay.satnav_fields if f not in bounds]
        if unbounded:
            raise ConfigError(f"{type(self).__name__}: sat-nav field(s) {', '.join(map(repr, unbounded))} have no "
                              "bounds; declare them in satnav_bounds, e.g. satnav_bounds = {"
                              f"{unbounded[0]!r}: (0.0, 1.0)}}")
        for name, (lo, hi) in bounds.items():
            if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
                raise ConfigError(f"{type(self).__name__}: satnav_bounds[{name!r}] must be finite with low < high, "
                                  f"got {(lo, hi)}")
        lidar_high = 1.0 / readout.MIN_DISTANCE if self.config.lidar_encoding == "inverse" else 1.0
        low = np.concatenate([np.zeros(lay.history * lay.n_rays),
                              np.tile([bounds[f][0] for f in lay.satnav_fields], lay.history)])
        high = np.concatenate([np.full(lay.history * lay.n_rays, lidar_high),
                               np.tile([bounds[f][1] for f in lay.satnav_fields], lay.history)])
        return spaces.Box(low.astype(np.float32), high.astype(np.float32), dtype=np.float32)

    # -- scenario hooks -----------------------------------------------------------------------
    def build_layout(self, rng: np.random.Generator) -> Layout:
        """Map and spawns of one episode, drawn from ``rng`` only."""
        raise NotImplementedError

    def satnav_extra_values(self) -> np.ndarray:
        """``(N, len(satnav_extras))`` scenario-specific sat-nav values."""
        return np.zeros((self.config.num_cars, 0))

    def reward_extra_values(self, cars: np.ndarray) -> np.ndarray:
        """``(len(cars), len(reward_extras))``: this decision's scenario-specific reward terms for
        ``cars`` (called after the world advanced, before any of them is removed)."""
        return np.zeros((len(cars), 0))

    def scenario_info(self, cars: np.ndarray) -> list[dict[str, Any]]:
        """Scenario-specific per-car facts added to ``infos`` (one dict per car in ``cars``)."""
        return [{} for _ in cars]

    # the keys ``scenario_info`` adds, with their meaning (the scenario pages print them)
    scenario_info_fields: dict[str, str] = {}

    def _seed(self, seed: Optional[int]) -> np.random.Generator:
        """The env's generator, made anew from ``seed`` where one is given (or none exists yet)."""
        if seed is not None or self.np_random is None:
            self.np_random, _ = seeding.np_random(seed)
        return self.np_random

    def _new_layout(self, seed: Optional[int], options: dict) -> Layout:
        """The episode's layout (the spline scenarios insert their path choice here)."""
        return self.build_layout(self._seed(seed))

    # -- API ----------------------------------------------------------------------------------
    def reset(self, seed: Optional[int] = None, options: Optional[dict] = None):
        cfg = self.config
        seed, options = check_reset_arguments(seed, options)
        if seed is not None:  # action_space(a).sample() is reproducible from the same seed
            self._act_space.seed(seed)
        self.layout = self._new_layout(seed, options)
        self.world.reset(self.layout)
        n = cfg.num_cars
        self.decision = 0
        self.agents = list(self.possible_agents)
        self._initial = self.world.s_goal - self.world.s
        self._goals = np.array([c.path.points[-1] if c.goal is None else c.goal for c in self.layout.cars])
        self._arrived_before = np.zeros(n, dtype=bool)
        self._light_index = np.array([c.light_index for c in self.layout.cars], dtype=np.int64)
        # tracks that bend (a turn at the junction): the paper's readings of such a car differ
        self._turned = np.array([len(c.path.points) > 2 for c in self.layout.cars], dtype=bool)
        self._prev_level = np.zeros(n)
        self._bits = np.zeros(n)
        self._received = np.zeros(n)
        self._seen = np.full(n, NO_LIGHT)
        self._lane_origin, self._lane_right, self._lane_half_width = _lane_axes(self.layout)
        self._stop_point, self._stop_direction, self._light_group = _stop_lines(self.layout, self._light_index)
        # where a car's light is seen from: its stop line, or (the paper's code) the point on its
        # arm's axis across from it
        self._view_point = (_axis_points(self._stop_point, self._stop_direction, self._lane_origin)
                            if self.sees_light_from_axis else self._stop_point)
        self._approach = [c.approach for c in self.layout.cars]
        cars = np.arange(n)
        self._acting = cars
        lidar_frame, satnav_frame = core.frames([self], [cars], senders=[np.zeros(0, dtype=np.int64)])
        self.history = FrameHistory(self.observation_layout, n)
        self.history.reset(lidar_frame, satnav_frame)
        obs = self.history.observations(cars)
        observations = {a: obs[i] for i, a in enumerate(self.agents)}
        infos = dict(zip(self.agents, core.car_infos([self], [cars])))
        return observations, infos

    def step(self, actions: dict[str, Any]):
        raw = check_actions(actions, self.agents, self.config.n_actions)
        d = core.step_instances([self], [raw])[0]
        # per-agent dicts only here, at the PettingZoo boundary, from the decision's arrays
        agents = [self.possible_agents[i] for i in d.cars.tolist()]
        done_list = d.terminated.tolist()
        observations = dict(zip(agents, d.observations))
        rewards = dict(zip(agents, d.rewards.tolist()))
        terminations = dict(zip(agents, done_list))
        truncations = {a: d.truncated and not t for a, t in zip(agents, done_list)}
        infos = dict(zip(agents, d.infos))
        return observations, rewards, terminations, truncations, infos

    def state(self) -> np.ndarray:
        w = self.world
        cols = [w.positions[:, 0], w.positions[:, 1], np.cos(w.headings), np.sin(w.headings),
                w.speed, w.accel, self._goals[:, 0], self._goals[:, 1],
                self._remaining() / self._initial, (w.status == ACTIVE).astype(float),
                w.has_arrived.astype(float), (w.status == COLLIDED).astype(float),
                w.ratings]
        lights = np.zeros(self.n_lights)
        if self.layout is None:
            raise RuntimeError("state() needs reset() first")
        if self.layout.lights is not None:
            lights[: len(self.layout.lights)] = self.layout.lights.values(self.time)
        return np.concatenate([np.stack(cols, axis=1).ravel(), lights,
                               [self.decision / self.config.horizon]]).astype(np.float32)

    def render(self) -> Optional[np.ndarray]:
        """Draw the current state: an ``(H, W, 3)`` uint8 frame in ``rgb_array`` mode, a window
        update in ``human`` mode (see :mod:`box2d_driving.render.viewer`)."""
        if self.render_mode is None:
            gymnasium_logger.warn("render() called without a render_mode; pass render_mode=...")
            return None
        if self.layout is None:
            raise RuntimeError("render() needs reset() first")
        if self._viewer is None:
            from box2d_driving.render.viewer import Viewer, ViewerConfig

            w, h = self.config.render_size
            self._viewer = Viewer(self.render_mode, ViewerConfig(width=w, height=h),
                                  show_lidar=self.config.render_lidar, fps=self.config.render_fps)
        return self._viewer.render(self.scene())

    def scene(self) -> "Scene":
        """What a frame of this moment shows (:class:`~box2d_driving.render.scene.Scene`): the map,
        the cars, pedestrians and lights, and the LiDAR rays when ``render_lidar`` is on."""
        from box2d_driving.render.scene import Scene

        if self.layout is None:
            raise RuntimeError("scene() needs reset() first")
        cfg, w = self.config, self.world
        lights = self.layout.lights
        rays, dropped = self._last_rays, self._last_dropped
        draw_rays = cfg.render_lidar and rays is not None and dropped is not None
        return Scene(
            name=self.metadata.get("name", ""), decision=self.decision, horizon=cfg.horizon,
            layout=self.layout, light_values=None if lights is None else lights.values(self.time),
            positions=w.positions.copy(), headings=w.headings.copy(), status=w.status.copy(),
            car_length=cfg.car_length, car_width=cfg.car_width,
            ped_positions=np.asarray(w.ped_positions).copy(), ped_sizes=np.asarray(w.ped_sizes).copy(),
            stop_value=cfg.render_stop_value,
            rays=rays.copy() if draw_rays and rays is not None else None,
            dropped=dropped.copy() if draw_rays and dropped is not None else None, lidar_range=cfg.lidar_range)

    def close(self) -> None:
        self.world.release()
        if self._viewer is not None:
            self._viewer.close()
            self._viewer = None

    # -- internals ----------------------------------------------------------------------------
    @property
    def time(self) -> float:
        """Seconds since reset."""
        return self.decision * self.config.decision_time

    def _remaining(self) -> np.ndarray:
        return self.world.s_goal - self.world.s

    def _lidar_distances(self, cars: np.ndarray) -> np.ndarray:
        """Noise-free LiDAR distances of ``cars`` (m, ``inf``: no return)."""
        return core.lidar_distances([self], [cars])

    def _receive(self, cars: np.ndarray, senders: np.ndarray) -> np.ndarray:
        """Bit of the nearest other sender within range and angle of each car's heading; with
        none, 0 or (``comm_fallback="own"``) the car's own last bit."""
        cfg, w = self.config, self.world
        out = self._bits[cars].astype(float) if cfg.comm_fallback == "own" else np.zeros(len(cars))
        if len(senders) == 0:
            return out
        rel = w.positions[senders][None, :, :] - w.positions[cars][:, None, :]
        dist = np.linalg.norm(rel, axis=2)
        bearing = wrap_angle(np.arctan2(rel[..., 1], rel[..., 0]) - w.headings[cars][:, None])
        ok = (dist <= cfg.comm_range) & (np.abs(bearing) <= cfg.comm_half_angle)
        ok &= senders[None, :] != cars[:, None]
        dist = np.where(ok, dist, np.inf)
        best = np.argmin(dist, axis=1)
        has = np.isfinite(dist[np.arange(len(cars)), best])
        out[has] = self._bits[senders[best[has]]]
        return out


def _lane_axes(layout: Layout) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Every car's lane axis as arrays: origins ``(N, 2)``, right-hand unit vectors ``(N, 2)`` and
    half widths ``(N,)``, NaN for cars without an axis."""
    n = len(layout.cars)
    origin, right, half = np.full((n, 2), np.nan), np.full((n, 2), np.nan), np.full(n, np.nan)
    for i, car in enumerate(layout.cars):
        if car.lane_axis is not None:
            origin[i], right[i], half[i] = car.lane_axis.origin, car.lane_axis.right, car.lane_axis.half_width
    return origin, right, half


def _axis_points(stop: np.ndarray, direction: np.ndarray, origin: np.ndarray) -> np.ndarray:
    """Each stop point ``(N, 2)`` moved across its approach onto the road axis through
    ``origin`` along ``direction`` (m): the point where that axis meets the stop line."""
    along = ((stop - origin) * direction).sum(axis=1, keepdims=True)
    return origin + along * direction


def _stop_lines(layout: Layout, light_index: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The stop-line centre ``(N, 2)``, travel direction ``(N, 2)`` and group ``(N,)`` of each
    car's light; NaN (group 0) for cars without one (no light on their approach, or no lights)."""
    n = len(light_index)
    point, direction = np.full((n, 2), np.nan), np.full((n, 2), np.nan)
    group = np.zeros(n, dtype=np.int64)
    has = light_index >= 0
    if layout.lights is not None and has.any():
        point[has] = layout.lights.stop_points[light_index[has]]
        direction[has] = layout.lights.directions[light_index[has]]
        group[has] = layout.lights.groups[light_index[has]]
    return point, direction, group
