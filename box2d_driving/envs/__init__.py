"""Scenarios as parameter-shared PettingZoo ``ParallelEnv``s; each versioned id also has a
PettingZoo-style module (``intersection_v0``: ``parallel_env``, ``env``, ``raw_env``;
:mod:`box2d_driving.envs.pettingzoo_style`)."""

from __future__ import annotations

from pettingzoo import ParallelEnv
from pettingzoo.utils import wrappers
from pettingzoo.utils.conversions import parallel_to_aec


def to_aec(parallel: ParallelEnv):
    """The AEC (turn-based) view of a parallel env, with PettingZoo's order checks."""
    return wrappers.OrderEnforcingWrapper(parallel_to_aec(parallel))

