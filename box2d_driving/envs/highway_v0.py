"""``highway-v0``: one-way highway, cars of different acceleration ratings (see :mod:`box2d_driving.envs.highway`)."""

from __future__ import annotations

from typing import Any

from box2d_driving.envs import to_aec
from box2d_driving.envs.highway import HighwayConfig, HighwayEnv

__all__ = ["HighwayConfig", "HighwayEnv", "env", "parallel_env", "raw_env"]


def parallel_env(**overrides: Any) -> HighwayEnv:
    """The parallel env; ``overrides`` are fields of :class:`HighwayConfig`."""
    return HighwayEnv(**overrides)


def env(**overrides: Any):
    """The AEC version of :func:`parallel_env`."""
    return to_aec(parallel_env(**overrides))


raw_env = env  # PettingZoo's convention: the AEC env
