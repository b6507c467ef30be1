"""``intersection-spline-v0``: signalled four-way junction, each car picks its own spline path
(lanes) (see :mod:`box2d_driving.envs.intersection_spline`)."""

from __future__ import annotations

from typing import Any

from box2d_driving.envs import to_aec
from box2d_driving.envs.intersection_spline import IntersectionSplineConfig, IntersectionSplineEnv

__all__ = ["IntersectionSplineConfig", "IntersectionSplineEnv", "env", "parallel_env", "raw_env"]


def parallel_env(**overrides: Any) -> IntersectionSplineEnv:
    """The parallel env; ``overrides`` are fields of :class:`IntersectionSplineConfig`."""
    return IntersectionSplineEnv(**overrides)


def env(**overrides: Any):
    """The AEC version of :func:`parallel_env`."""
    return to_aec(parallel_env(**overrides))


raw_env = env  # PettingZoo's convention: the AEC env
