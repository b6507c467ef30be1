"""``intersection-v0``: signalled four-way junction, fixed straight tracks
(see :mod:`box2d_driving.envs.intersection`)."""

from __future__ import annotations

from typing import Any

from box2d_driving.envs import to_aec
from box2d_driving.envs.intersection import IntersectionConfig, IntersectionEnv

__all__ = ["IntersectionConfig", "IntersectionEnv", "env", "parallel_env", "raw_env"]


def parallel_env(**overrides: Any) -> IntersectionEnv:
    """The parallel env; ``overrides`` are fields of :class:`IntersectionConfig`."""
    return IntersectionEnv(**overrides)


def env(**overrides: Any):
    """The AEC version of :func:`parallel_env`."""
    return to_aec(parallel_env(**overrides))


raw_env = env  # PettingZoo's convention: the AEC env
