"""``crosswalk-v0``: highway with a crosswalk and crossing pedestrians (see :mod:`box2d_driving.envs.crosswalk`)."""

from __future__ import annotations

from typing import Any

from box2d_driving.envs import to_aec
from box2d_driving.envs.crosswalk import CrosswalkConfig, CrosswalkEnv

__all__ = ["CrosswalkConfig", "CrosswalkEnv", "env", "parallel_env", "raw_env"]


def parallel_env(**overrides: Any) -> CrosswalkEnv:
    """The parallel env; ``overrides`` are fields of :class:`CrosswalkConfig`."""
    return CrosswalkEnv(**overrides)


def env(**overrides: Any):
    """The AEC version of :func:`parallel_env`."""
    return to_aec(parallel_env(**overrides))


raw_env = env  # PettingZoo's convention: the AEC env
