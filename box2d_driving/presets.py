"""Named presets: sets of config values chosen together, selected by name.

``make("intersection-v0", preset="paper")`` builds the world of the paper's own code (sdriving
0.1.0) where our defaults differ: cars that stay after arriving and can reverse, spawns anywhere
on the middle of their arm, goals on the road axis reached within a third of the road width,
walls at the arms' ends, lights that start at the beginning of green or red, LiDAR with a 5 m
minimum range and rays dropped independently, a squared smoothness term and a 25-decision
horizon. Keyword overrides still apply on top (``make(..., preset="paper", lidar_noise=0.25)``).
Each value and the original file and symbol it comes from are tabled in the docs' page "Our
world and the paper's" (``docs/paper_world.md``), with what each changes and what still differs.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

from box2d_driving.config import ConfigError


@dataclass(frozen=True)
class Preset:
    """A named set of config values per env id.

    Attributes:
        name: what ``preset=`` takes.
        description: one line for listings.
        env_overrides: env id -> config field values.
    """

    name: str
    description: str
    env_overrides: dict[str, dict[str, Any]] = field(default_factory=dict)


PAPER = Preset(
    name="paper",
    description="the world of the paper's own code, sdriving 0.1.0 (docs/paper_world.md)",
    env_overrides={
        "intersection-v0": {
            "horizon": 25,  # horizon=250 physics steps, timesteps=10 per decision
            "arrived_cars_stay": True,  # dones = collision + timeout
            "reverse": True,  # speed in [-v_lim, v_lim] (the bicycle model's v_lim_neg)
            "spawn_mode": "arm", "arm_spawn_range": (0.2, 0.8),  # road.sample(x_bound=0.6)
            "lane_offset_range": (0.15, 0.30),  # lane_side * U[0.15, 0.30) * width
            "approach_order": "rotate",  # balance_cars=True
            "goal_radius": 1.0 / 3.0,  # reached when distance <= width / 3
            "road_end_walls": True,  # closed=[True] * 4
            "light_start": "green_or_red", "light_period_step": 0.1,  # start_signal 0 or 2; int steps
            "lidar_dropout": "independent", "lidar_min_range": 5.0,  # rand > p; BatchedVehicle min_lidar_range=5.0
            "smoothness": "squared",  # (a_t - a_{t-1})^2 / (2 * 1.5)^2
            "drive_on": "left",  # lane_side=1: every car left of its road's axis
            "arrived_heading_error": "minus_heading",  # destination := position, atan2(0, 0) - heading
            "goal_distance": "straight",  # 1 / clamp(distance_from_destination(), min=1)
            "light_view": "axis_point",  # get_traffic_signal: |road end on the axis - centre| < vision_range
            "integration": "euler",  # _BicycleKinematicsModel: x += v * dt * cos(theta), then v += a * dt
        },
    },
)

PAPER_TURNS = Preset(
    name="paper-turns",
    description="the paper's code's turning junction, as its lone-car run has it (docs/paper_world.md)",
    env_overrides={
        "intersection-v0": {
            **PAPER.env_overrides["intersection-v0"],
            "horizon": 20,  # horizon=200 physics steps
            "turns": True,  # turns=True: the exit among the three other roads
            "turn_motion": "paper",  # _FixedTrackAccelerationModel
            "light_first_green": 0.125,  # learn_right_of_way: merged phases, ordering in range(8)
        },
    },
)

PRESETS = {p.name: p for p in (PAPER, PAPER_TURNS)}


def preset_overrides(name: str, env_id: str) -> dict[str, Any]:
    """The config values preset ``name`` sets for ``env_id`` (a copy); :class:`ConfigError` for an
    unknown preset or one that does not cover the env."""
    if name not in PRESETS:
        raise ConfigError(f"unknown preset {name!r}; presets: {', '.join(PRESETS)}")
    preset = PRESETS[name]
    if env_id not in preset.env_overrides:
        raise ConfigError(f"preset {name!r} has no settings for {env_id!r}; it covers "
                          f"{', '.join(preset.env_overrides)}")
    return dict(preset.env_overrides[env_id])
