"""``real-junction-v0``: real junctions from map files: lanes, connectors, real signals
(see :mod:`box2d_driving.envs.real_junction`)."""

from __future__ import annotations

from typing import Any

from box2d_driving.envs import to_aec
from box2d_driving.envs.real_junction import RealJunctionConfig, RealJunctionEnv

__all__ = ["RealJunctionConfig", "RealJunctionEnv", "env", "parallel_env", "raw_env"]


def parallel_env(**overrides: Any) -> RealJunctionEnv:
    """The parallel env; ``overrides`` are fields of :class:`RealJunctionConfig`."""
    return RealJunctionEnv(**overrides)


def env(**overrides: Any):
    """The AEC version of :func:`parallel_env`."""
    return to_aec(parallel_env(**overrides))


raw_env = env  # PettingZoo's convention: the AEC env
