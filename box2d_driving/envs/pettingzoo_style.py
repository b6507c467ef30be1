"""PettingZoo-style modules (``from box2d_driving.envs import intersection_v0``): each versioned
id's ``parallel_env``, ``env`` and ``raw_env``, made from its scenario record."""

from __future__ import annotations

from typing import Any, Callable

from pettingzoo import ParallelEnv

from box2d_driving.envs import to_aec
from box2d_driving.scenarios import scenario


def module_functions(env_id: str) -> tuple[Callable[..., Any], Callable[..., Any], Callable[..., Any]]:
    """``parallel_env``, ``env`` and ``raw_env`` for ``env_id``; keyword arguments are fields of
    its config."""

    def parallel_env(**overrides: Any) -> ParallelEnv:
        return scenario(env_id).parallel_env(**overrides)

    def env(**overrides: Any):
        return to_aec(parallel_env(**overrides))

    parallel_env.__doc__ = f"The parallel ``{env_id}`` env; keyword arguments are fields of its config."
    env.__doc__ = f"The AEC version of ``{env_id}`` (PettingZoo's order checks on)."
    return parallel_env, env, env
