"""Typed, frozen configuration shared by every scenario.

Every number the world uses lives here (or in a scenario's subclass of :class:`DrivingConfig`).
Units: metres, seconds, radians, metres per second (squared). Invalid values are rejected when the
config is constructed, with a message that names the field.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from typing import Any, Optional

from box2d_driving.fields import coerce_fields


class ConfigError(ValueError):
    """A configuration value, override name, env id or input file is invalid."""


def accel_levels(low: float, high: float, step: float) -> tuple[float, ...]:
    """Evenly spaced acceleration levels from ``low`` to ``high`` inclusive (m/s^2)."""
    n = int(round((high - low) / step)) + 1
    return tuple(round(low + i * step, 10) for i in range(n))


LIDAR_ENCODINGS = ("inverse", "proximity")
LIDAR_BACKENDS = ("auto", "numba", "box2d")
RENDER_MODES = (None, "rgb_array", "human")
COMM_FALLBACKS = ("zero", "own")
LIGHT_STARTS = ("random_phase", "green_or_red")
LIDAR_DROPOUTS = ("exact", "independent")
SMOOTHNESS = ("linear", "squared")
ARRIVED_HEADING_ERRORS = ("zero", "minus_heading")
GOAL_DISTANCES = ("path", "straight")
INTEGRATIONS = ("exact", "euler")


@dataclass(frozen=True)
class DrivingConfig:
    """Fields common to every scenario.

    Attributes:
        num_cars: number of cars (agents) per episode.
        horizon: episode length in decisions; reaching it truncates.
        dt: physics step (s).
        substeps: physics steps per decision; an action is held for ``dt * substeps`` seconds.
        history: number of stacked observation frames (oldest first).
        n_rays: LiDAR rays, equally spaced over 360 degrees starting at the heading.
        lidar_range: LiDAR range (m).
        lidar_noise: share of rays dropped (set to 0) at every decision, exactly
            ``round(lidar_noise * n_rays)`` of them.
        lidar_encoding: ``"inverse"`` (1 / distance, 0 = no return, the paper's) or
            ``"proximity"`` (1 - distance / range, 0 = no return).
        lidar_sees_pedestrians: whether LiDAR rays hit pedestrians (False makes them invisible,
            still solid: a control for behaviour that comes from perception).
        lidar_backend: ``"numba"`` (batched, default through ``"auto"``) or ``"box2d"``
            (``world.RayCast`` callbacks); they agree within 1e-3 m.
        communication: each car also sends one bit per decision (action space doubles).
        messages_heard: with ``communication``, whether cars hear the bits (False: every car
            receives 0 while the bits are still sent; a control for whether listeners use them).
        comm_range: a car hears the nearest other car within this distance (m) ...
        comm_half_angle: ... and within this angle of its heading (rad).
        comm_fallback: what a car receives when no other car is in range: ``"zero"`` (the paper's rule)
            or ``"own"``, its own last bit (a 1-bit memory; an ablation: the original code's
            nearest-sender rule could pick the receiver itself when no other car was visible).
        car_length, car_width: car body size (m).
        v_lim: speed limit (m/s); speed is clipped to ``[0, v_lim]``.
        accelerations: the discrete longitudinal accelerations (m/s^2).
        remove_collided: remove a collided car from the world instead of leaving it halted.
        light_view_distance: a car sees its approach's light within this distance before the
            stop line (m).
        light_period_range: ``T ~ U[low, high)`` (s); a light cycles green ``T - yellow``,
            yellow ``yellow``, red ``T - yellow``, yellow ``yellow``.
        light_yellow: yellow duration (s).
        goal_reward: reward on the decision a car reaches its goal.
        collision_reward: reward on the decision of a car's first collision.
        render_mode: ``None``, ``"rgb_array"`` (``render()`` returns an ``(H, W, 3)`` uint8
            frame) or ``"human"`` (a pygame window).
        render_size: frame ``(width, height)`` in pixels.
        render_lidar: draw LiDAR rays (dropped rays in a different colour).
        render_fps: frames per second of ``human`` playback and recorded videos.
        render_stop_value: the light value drawn red, 1.0 (red) or 0.0 (green). The two light
            groups are symmetric, so a trained policy may adopt either value as "stop"; when one is
            shown, the value it stops on is drawn red and the other green (yellow stays yellow),
            and the picture's legend says so.
        arrived_cars_stay: a car that reaches its goal stays in the world and keeps deciding until
            it collides or the horizon ends the episode (the paper's code); its progress term
            becomes ``-(1/H) * |v| / v_lim`` (stop at the goal) and it can still crash. False:
            it leaves the world on arrival and its trajectory ends there.
        reverse: speed in ``[-v_lim, v_lim]``: braking from a standstill backs the car along its
            path (the paper's code). False: speed in ``[0, v_lim]``.
        light_start: ``"random_phase"`` (a uniformly random point of the cycle at reset) or
            ``"green_or_red"`` (the paper's code: each group starts at the beginning of green or
            of red, at random).
        light_first_green: with ``"green_or_red"``, the probability that light group 0 starts at
            the beginning of green (else the other group does): 1/2 in the paper's code's 4-car
            world, 1/8 in its turning world (``ordering in range(8)``).
        light_period_step: ``T`` is drawn on a grid of this step (s); the paper's code draws it in
            physics steps of 0.1 s. 0: continuous.
        lidar_dropout: ``"exact"`` (exactly ``round(lidar_noise * n_rays)`` rays dropped) or
            ``"independent"`` (each ray dropped with probability ``lidar_noise``, the paper's code).
        lidar_min_range: returns nearer than this are dropped (m); the paper's code uses 5 m.
        smoothness: ``"linear"`` (``-(1/H) |a_t - a_{t-1}| / (a_hi - a_lo)``) or ``"squared"``
            (``-(1/H) ((a_t - a_{t-1}) / (a_hi - a_lo))^2``, the paper's code).
        arrived_heading_error: the sat-nav heading error of a car past its goal: ``"zero"``, or
            ``"minus_heading"``, minus the car's heading in world coordinates wrapped to
            ``[-pi, pi)`` (rad), as the paper's code reads it once it has moved an arrived car's
            goal onto the car (``atan2(0, 0) - heading``; a car heading due west reads -pi there,
            and here), for good: a car that backs out past its goal still reads it (with
            ``"zero"``, such a car reads its track again).
        goal_distance: the distance the sat-nav's ``1 / max(distance, 1)`` reads: ``"path"``, the
            length of track left to drive to the arrival point (m), or ``"straight"``, the
            straight-line distance from the car to its goal point (m), as the paper's code reads it
            (with a ``goal_radius`` that point is on the road axis and a car arrives ``r * W``
            short of it); once a car is past its goal, either reads 1 (``"straight"`` from its
            arrival on, as the paper's code, even if it backs out past its goal again).
        integration: how a car's speed and arc length advance over a physics step of ``dt``:
            ``"exact"`` (the acceleration held over the step, the speed clipped where it reaches
            a limit inside it) or ``"euler"`` (the paper's code: the car moves ``v * dt`` at the
            speed ``v`` of the step's start, then ``v`` becomes ``clip(v + a * dt)``; an
            accelerating car covers ``a * dt^2 / 2`` less per step, a braking one as much more).
    """

    num_cars: int = 4
    horizon: int = 25
    dt: float = 0.1
    substeps: int = 10
    history: int = 5
    n_rays: int = 100
    lidar_range: float = 50.0
    lidar_noise: float = 0.0
    lidar_encoding: str = "inverse"
    lidar_backend: str = "auto"
    lidar_sees_pedestrians: bool = True
    communication: bool = False
    messages_heard: bool = True
    comm_range: float = 30.0
    comm_half_angle: float = math.pi / 6
    comm_fallback: str = "zero"
    car_length: float = 4.48
    car_width: float = 2.2
    v_lim: float = 8.0
    accelerations: tuple[float, ...] = accel_levels(-1.5, 1.5, 0.25)
    remove_collided: bool = False
    light_view_distance: float = 30.0
    light_period_range: tuple[float, float] = (10.0, 15.0)
    light_yellow: float = 1.0
    goal_reward: float = 1.0
    collision_reward: float = -1.0
    render_mode: Optional[str] = None
    render_size: tuple[int, int] = (768, 768)
    render_lidar: bool = False
    render_fps: float = 4.0
    render_stop_value: float = 1.0
    arrived_cars_stay: bool = False
    reverse: bool = False
    light_start: str = "random_phase"
    light_first_green: float = 0.5
    light_period_step: float = 0.0
    lidar_dropout: str = "exact"
    lidar_min_range: float = 0.0
    smoothness: str = "linear"
    arrived_heading_error: str = "zero"
    goal_distance: str = "path"
    integration: str = "exact"

    # Box2D moves a body at most this far in one step (b2_maxTranslation).
    _BOX2D_MAX_TRANSLATION = 2.0

    _SLOTS_SET_BY = "the scenario"  # what decides max_cars(), for the num_cars message
    # Upper limits of integer fields: beyond them an episode would take hours or gigabytes.
    _INT_MAX = {"horizon": 100_000, "substeps": 1_000, "history": 100, "n_rays": 4_096}

    def __post_init__(self) -> None:
        coerce_fields(self, ConfigError)  # kinds first: every check below sees plain values
        self._validate()

    # -- validation -------------------------------------------------------------------------
    def _validate(self) -> None:
        _int_at_least(self, "num_cars", 1)
        if self.num_cars > self.max_cars():
            raise ConfigError(
                f"num_cars={self.num_cars} exceeds the {self.max_cars()} spawn slots of "
                f"{type(self).__name__} (set by {self._SLOTS_SET_BY})"
            )
        for name, high in self._INT_MAX.items():
            _int_at_least(self, name, 1, high)
        _positive(self, "dt")
        _positive(self, "lidar_range")
        _positive(self, "car_length")
        _positive(self, "car_width")
        _positive(self, "v_lim")
        _positive(self, "comm_range")
        _positive(self, "light_view_distance")
        if not 0.0 <= self.lidar_noise <= 1.0:
            raise ConfigError(f"lidar_noise must be in [0, 1], got {self.lidar_noise}")
        _choice(self, "lidar_encoding", LIDAR_ENCODINGS)
        _choice(self, "lidar_backend", LIDAR_BACKENDS)
        _choice(self, "render_mode", RENDER_MODES)
        _choice(self, "comm_fallback", COMM_FALLBACKS)
        _choice(self, "light_start", LIGHT_STARTS)
        if not 0.0 <= self.light_first_green <= 1.0:
            raise ConfigError(f"light_first_green must be in [0, 1], got {self.light_first_green}")
        _choice(self, "lidar_dropout", LIDAR_DROPOUTS)
        _choice(self, "smoothness", SMOOTHNESS)
        _choice(self, "arrived_heading_error", ARRIVED_HEADING_ERRORS)
        _choice(self, "goal_distance", GOAL_DISTANCES)
        _choice(self, "integration", INTEGRATIONS)
        for name in ("light_period_step", "lidar_min_range"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not 0.0 <= value < math.inf:
                raise ConfigError(f"{name} must be a number >= 0, got {value!r}")
        if self.lidar_min_range >= self.lidar_range:
            raise ConfigError(f"lidar_min_range ({self.lidar_min_range!r} m) must be below lidar_range "
                              f"({self.lidar_range!r} m)")
        if any(not 16 <= v <= 8192 for v in self.render_size):
            raise ConfigError(f"render_size must be two integers in [16, 8192], got {self.render_size!r}")
        _positive(self, "render_fps")
        if self.render_stop_value not in (0.0, 1.0):
            raise ConfigError(f"render_stop_value must be 0.0 or 1.0 (the light value drawn red), "
                              f"got {self.render_stop_value!r}")
        if self.light_yellow < 0:
            raise ConfigError(f"light_yellow must be >= 0 s, got {self.light_yellow!r}")
        if not 0.0 < self.comm_half_angle <= math.pi:
            raise ConfigError(f"comm_half_angle must be in (0, pi] rad, got {self.comm_half_angle!r}")
        require(self, len(self.accelerations) >= 2, ("accelerations",), "accelerations needs at least two levels")
        require(self, list(self.accelerations) == sorted(set(self.accelerations)), ("accelerations",),
                "accelerations must be strictly increasing")
        lo, hi = self.light_period_range
        if not (2 * self.light_yellow < lo < hi):
            raise ConfigError(
                "light_period_range must satisfy 2 * light_yellow < low < high, "
                f"got {self.light_period_range} with light_yellow={self.light_yellow}"
            )
        # No tunnelling: per physics step, the closing distance of any two bodies must stay
        # below the extent they must cross to pass through each other (road edges are thin).
        step = self.max_speed() * self.dt
        car = min(self.car_width, self.car_length)
        if step >= self._BOX2D_MAX_TRANSLATION:
            raise ConfigError(
                f"a car would move {step:.2f} m per physics step (v_lim={self.v_lim!r} m/s x "
                f"dt={self.dt!r} s), more than Box2D's {self._BOX2D_MAX_TRANSLATION} m limit: lower v_lim or dt"
            )
        if step >= car:
            raise ConfigError(
                f"a car moves {step:.2f} m per physics step (v_lim={self.v_lim!r} m/s x dt={self.dt!r} s), "
                f"not less than its smallest extent (car_length={self.car_length!r}, "
                f"car_width={self.car_width!r} m): it could tunnel through a road edge; lower v_lim "
                f"or dt, or enlarge the car"
            )
        ped_closing = step + self.max_obstacle_speed() * self.dt
        if ped_closing >= car + self.min_obstacle_size():
            raise ConfigError(
                f"a car and a pedestrian close {ped_closing:.2f} m per physics step (v_lim={self.v_lim!r}, "
                f"dt={self.dt!r} and pedestrian_speed_range), more than a car and a pedestrian "
                f"(pedestrian_size) are wide: they could tunnel through each other; lower v_lim or dt"
            )

    # -- derived ------------------------------------------------------------------------------
    def max_cars(self) -> int:
        """Number of distinct spawn slots (scenarios override)."""
        return 64

    def max_speed(self) -> float:
        """Highest speed any car can reach (m/s)."""
        return self.v_lim

    def max_obstacle_speed(self) -> float:
        """Highest speed of a moving non-car body (pedestrians) (m/s)."""
        return 0.0

    def min_obstacle_size(self) -> float:
        """Smallest extent of a non-car body a car can hit (m); infinite when there is none."""
        return math.inf

    @property
    def wrecks_stay(self) -> bool:
        """A collided car stays in the world as a halted obstacle (the default; not ``remove_collided``)."""
        return not self.remove_collided

    @property
    def a_max(self) -> float:
        """Largest acceleration magnitude (m/s^2)."""
        return max(abs(a) for a in self.accelerations)

    @property
    def decision_time(self) -> float:
        """Seconds per decision."""
        return self.dt * self.substeps

    @property
    def n_actions(self) -> int:
        return len(self.accelerations) * (2 if self.communication else 1)

    @classmethod
    def field_names(cls) -> list[str]:
        return [f.name for f in dataclasses.fields(cls)]

    @classmethod
    def from_overrides(cls, **overrides: Any) -> "DrivingConfig":
        """Build a config from keyword overrides, rejecting unknown names."""
        valid = cls.field_names()
        unknown = sorted(set(overrides) - set(valid))
        if unknown:
            raise ConfigError(
                f"unknown override(s) {', '.join(unknown)} for {cls.__name__}; "
                f"valid: {', '.join(valid)}"
            )
        try:
            return cls(**overrides)
        except TypeError as exc:  # e.g. a tuple field given a scalar
            raise ConfigError(f"{cls.__name__}: {exc}") from exc


def require(cfg: Any, ok: bool, fields: tuple[str, ...], rule: str) -> None:
    """Raise :class:`ConfigError` stating ``rule`` and the values of ``fields`` unless ``ok``
    (for constraints between fields: the message names every field involved)."""
    if not ok:
        values = ", ".join(f"{n}={getattr(cfg, n)!r}" for n in fields)
        raise ConfigError(f"{type(cfg).__name__}: {rule} (got {values})")


def _int_at_least(cfg: Any, name: str, low: int, high: Optional[int] = None) -> None:
    value = getattr(cfg, name)
    if isinstance(value, bool) or not isinstance(value, int) or value < low or (high is not None and value > high):
        allowed = f">= {low}" if high is None else f"in [{low}, {high}]"
        raise ConfigError(f"{name} must be an integer {allowed}, got {value!r}")


def _positive(cfg: Any, name: str) -> None:
    value = getattr(cfg, name)
    if not isinstance(value, (int, float)) or isinstance(value, bool) or not value > 0:
        raise ConfigError(f"{name} must be a positive number, got {value!r}")


def _choice(cfg: Any, name: str, options: tuple) -> None:
    value = getattr(cfg, name)
    if value not in options:
        raise ConfigError(f"{name} must be one of {options}, got {value!r}")
