"""Scripted policies usable wherever a trained policy is: ``act(observations) -> actions``.

* :class:`RandomPolicy`: uniform random actions (seeded).
* :class:`FullThrottlePolicy`: the largest acceleration always (bit 0): driving blind, the lower
  reference for every safety metric.
* :class:`ConstantSpeedPolicy`: light-blind, holding half the speed limit: at each decision the
  acceleration level that would bring the car to its target speed by the next one.
* :class:`LightRulePolicy`: the crude hand rule for the intersection: brake hard while the light
  shows 0.5 or 1.0 (yellow or red in the default colours), otherwise accelerate fully. A reference
  for what obeying the lights achieves, and a check on the metric code.
* :class:`PedestrianOraclePolicy`: a privileged crosswalk reference that reads every pedestrian's
  position and velocity from the world (no LiDAR) and takes the largest acceleration whose
  forward simulation keeps the car clear of every pedestrian: proof that the task is solvable,
  and an upper reference for the learned policy.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from box2d_driving.road.lights import RED, YELLOW


class RandomPolicy:
    """Uniform random actions from each agent's action space."""

    def __init__(self, env: Any, seed: int | None = None) -> None:
        self.env = env
        self.rng = np.random.default_rng(seed)

    def act(self, observations: dict[str, np.ndarray]) -> dict[str, int]:
        return {a: int(self.rng.integers(self.env.action_space(a).n)) for a in observations}


class FullThrottlePolicy:
    """The largest acceleration level for every car, every decision (bit 0)."""

    def __init__(self, env: Any) -> None:
        self._go = len(env.config.accelerations) - 1

    def act(self, observations: dict[str, np.ndarray]) -> dict[str, int]:
        return {a: self._go for a in observations}


CONSTANT_SPEED_FRACTION = 0.5  # the constant-speed driver's target, as a share of the speed limit


class ConstantSpeedPolicy:
    """Hold ``fraction`` of the speed limit, blind to the light and to other cars.

    At each decision every car takes the acceleration level nearest to ``(target - v) / T``, the
    acceleration that brings it from its speed ``v`` (read from its sat-nav, ``v / v_lim``) to
    ``target = fraction * v_lim`` in one decision of ``T = dt * substeps`` seconds: full throttle
    from a standstill, braking above the target, and from the target on the level nearest zero.
    A car's rating scales its limit and its accelerations alike, so the rule reads the same for
    every rating. The paper-world comparison (``original compare``) drives the same rule in the
    paper's simulator.

    Args:
        fraction: the target speed as a share of the speed limit, in ``(0, 1]``.
    """

    def __init__(self, env: Any, fraction: float = CONSTANT_SPEED_FRACTION) -> None:
        if not 0.0 < fraction <= 1.0:
            raise ValueError(f"constant-speed fraction must lie in (0, 1], got {fraction!r}")
        self._speed = env.observation_layout.newest("speed")
        cfg = env.config
        self._levels = np.asarray(cfg.accelerations, dtype=float)
        self._fraction = fraction
        self._gain = cfg.v_lim / (cfg.dt * cfg.substeps)  # m/s^2 per unit of v / v_lim, over one decision

    def act(self, observations: dict[str, np.ndarray]) -> dict[str, int]:
        return {a: nearest_level(self._levels, (self._fraction - float(o[self._speed])) * self._gain)
                for a, o in observations.items()}


def nearest_level(levels: np.ndarray, wanted: float) -> int:
    """The index of the level nearest ``wanted`` (m/s^2); on a tie, the lower one."""
    return int(np.argmin(np.abs(levels - wanted)))


class LightRulePolicy:
    """Brake while the light seen is in ``stop_values``, else full acceleration (bit 0)."""

    def __init__(self, env: Any, stop_values: tuple[float, ...] = (YELLOW, RED)) -> None:
        self._light = env.observation_layout.newest("light")
        self._stop_values = np.asarray(stop_values)
        self._brake = 0
        self._go = len(env.config.accelerations) - 1

    def act(self, observations: dict[str, np.ndarray]) -> dict[str, int]:
        return {a: self._brake if np.any(np.isclose(o[self._light], self._stop_values)) else self._go
                for a, o in observations.items()}


class PedestrianOraclePolicy:
    """Privileged crosswalk reference (reads ``env.world``; the env must be the one it drives).

    For every live car, tries the acceleration levels from the largest down and keeps the first
    whose constant-acceleration forward simulation over ``lookahead`` seconds (speed clipped to
    ``[0, v_lim * rating]``), against every pedestrian walking on at its current velocity, keeps
    the boxes at least ``clearance`` metres apart; full braking if none does. Other cars are
    ignored (so rear-end crashes remain).

    Args:
        lookahead: seconds simulated ahead.
        clearance: extra gap kept around the car's and pedestrian's boxes (m).
        samples: time samples over the lookahead.
    """

    privileged = True  # reads the world it was built with, not the observations

    def __init__(self, env: Any, lookahead: float = 6.0, clearance: float = 0.5, samples: int = 61) -> None:
        self.env = env
        cfg = env.config
        self._levels = np.asarray(cfg.accelerations, dtype=float)
        self._t = np.linspace(0.0, lookahead, samples)
        self._half = np.array([cfg.car_length / 2, cfg.car_width / 2]) + clearance

    def _safe(self, i: int, accel: float) -> bool:
        w, t = self.env.world, self._t
        if not len(w.ped_positions):
            return True
        v_max = self.env.config.v_lim * w.ratings[i]
        v = np.clip(w.speed[i] + accel * w.ratings[i] * t, 0.0, v_max)
        s = np.concatenate([[0.0], np.cumsum(0.5 * (v[1:] + v[:-1]) * np.diff(t))])
        heading = np.array([np.cos(w.headings[i]), np.sin(w.headings[i])])
        car = w.positions[i] + s[:, None] * heading  # (T, 2), straight ahead
        peds = w.ped_positions[None, :, :] + t[:, None, None] * w.ped_velocity[None, :, :]  # (T, P, 2)
        gap = np.abs(peds - car[:, None, :])
        reach = self._half[None, None, :] + w.ped_sizes[None, :, None] / 2
        return not np.any(np.all(gap < reach, axis=2))

    def act(self, observations: dict[str, np.ndarray]) -> dict[str, int]:
        out = {}
        for agent in observations:
            i = int(agent.rsplit("_", 1)[1])
            out[agent] = next((k for k in range(len(self._levels) - 1, -1, -1)
                               if self._safe(i, self._levels[k])), 0)
        return out


SCRIPTED = {"random": RandomPolicy, "full-throttle": FullThrottlePolicy, "constant-speed": ConstantSpeedPolicy,
            "rule": LightRulePolicy, "pedestrian-oracle": PedestrianOraclePolicy}


def make_policy(name: str, env: Any, seed: int | None = None):
    """A scripted policy by name (``random``, ``full-throttle``, ``constant-speed``, ``rule`` or
    ``pedestrian-oracle``)."""
    if name == "random":
        return RandomPolicy(env, seed)
    if name == "full-throttle":
        return FullThrottlePolicy(env)
    if name == "constant-speed":
        return ConstantSpeedPolicy(env)
    if name == "rule":
        return LightRulePolicy(env)
    if name == "pedestrian-oracle":
        return PedestrianOraclePolicy(env)
    raise ValueError(f"unknown policy {name!r}; scripted policies: {', '.join(SCRIPTED)}")
