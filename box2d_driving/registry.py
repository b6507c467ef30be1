"""Versioned env ids: ``make(env_id, **overrides)`` and ``registry()``."""

from __future__ import annotations

import importlib
from dataclasses import dataclass
from typing import Any, Optional

from box2d_driving.compile_note import note_first_compile
from box2d_driving.config import ConfigError
from box2d_driving.presets import preset_overrides


@dataclass(frozen=True)
class EnvSpec:
    """One registered env: its id, the module that provides ``parallel_env``, a description."""

    env_id: str
    module: str
    description: str


_SPECS = {
    spec.env_id: spec
    for spec in (
        EnvSpec("intersection-v0", "box2d_driving.envs.intersection_v0",
                "signalled four-way junction, fixed straight tracks (traffic lights)"),
        EnvSpec("highway-v0", "box2d_driving.envs.highway_v0",
                "one-way highway, cars of different acceleration ratings (safe distance)"),
        EnvSpec("crosswalk-v0", "box2d_driving.envs.crosswalk_v0",
                "highway with a crosswalk and crossing pedestrians (slow down for pedestrians)"),
        EnvSpec("intersection-spline-v0", "box2d_driving.envs.intersection_spline_v0",
                "signalled junction; each car picks its own spline path first (lanes emerge)"),
        EnvSpec("highway-spline-v0", "box2d_driving.envs.highway_spline_v0",
                "one-way highway; each car picks its own lateral target first (fast lanes emerge)"),
        EnvSpec("real-junction-v0", "box2d_driving.envs.real_junction_v0",
                "real junctions from OpenStreetMap: lanes, turns, real signals (right of way)"),
    )
}


def registry() -> dict[str, str]:
    """Registered env ids with one-line descriptions."""
    return {k: v.description for k, v in _SPECS.items()}


def env_module(env_id: str):
    """The PettingZoo-style module of ``env_id`` (has ``parallel_env`` and ``env``)."""
    if env_id not in _SPECS:
        raise ConfigError(f"unknown env id {env_id!r}; registered: {', '.join(_SPECS)}")
    return importlib.import_module(_SPECS[env_id].module)


def make(env_id: str, preset: Optional[str] = None, **overrides: Any):
    """Create the parallel env ``env_id`` with config ``overrides`` (e.g. ``num_cars=8``), on top
    of the named ``preset``'s values where one is given (``preset="paper"``: the world of the
    paper's own code; :mod:`box2d_driving.presets`)."""
    module = env_module(env_id)
    if preset is not None:
        overrides = {**preset_overrides(preset, env_id), **overrides}
    note_first_compile()  # a silent wait of up to 40 s on a fresh install otherwise
    return module.parallel_env(**overrides)
