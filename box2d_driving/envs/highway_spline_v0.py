"""``highway-spline-v0``: one-way highway, each car picks its own lateral target (fast lanes)
(see :mod:`box2d_driving.envs.highway_spline`)."""

from __future__ import annotations

from typing import Any

from box2d_driving.envs import to_aec
from box2d_driving.envs.highway_spline import HighwaySplineConfig, HighwaySplineEnv

__all__ = ["HighwaySplineConfig", "HighwaySplineEnv", "env", "parallel_env", "raw_env"]


def parallel_env(**overrides: Any) -> HighwaySplineEnv:
    """The parallel env; ``overrides`` are fields of :class:`HighwaySplineConfig`."""
    return HighwaySplineEnv(**overrides)


def env(**overrides: Any):
    """The AEC version of :func:`parallel_env`."""
    return to_aec(parallel_env(**overrides))


raw_env = env  # PettingZoo's convention: the AEC env
