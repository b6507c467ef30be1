"""Scenarios as parameter-shared PettingZoo ``ParallelEnv``s, one module per versioned id."""

from __future__ import annotations

from pettingzoo import ParallelEnv
from pettingzoo.utils import wrappers
from pettingzoo.utils.conversions import parallel_to_aec


def to_aec(parallel: ParallelEnv):
    """The AEC (turn-based) view of a parallel env, with PettingZoo's order checks."""
    return wrappers.OrderEnforcingWrapper(parallel_to_aec(parallel))
