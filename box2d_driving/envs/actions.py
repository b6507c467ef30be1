"""Checking a step's actions: one clear error naming the agent and the value."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np


# exact types (not bool, a subclass of int) whose in-range values convert to int64 unchanged
_PLAIN_INTS = (int, np.int64, np.int32)


class ActionError(ValueError):
    """An action dict that does not fit the live agents or the action space."""


def check_actions(actions: Any, agents: list[str], n_actions: int) -> np.ndarray:
    """The actions of the live ``agents`` (in that order) as an int64 array, or
    :class:`ActionError` naming the agent and value: every live agent needs exactly one integer
    (Python or numpy, also a 0-d integer array) in ``[0, n_actions)``, and no other agent may
    appear (one that is done, or was never in the episode)."""
    if not agents:
        raise ActionError("step() called after all agents are done; call reset()")
    if not isinstance(actions, Mapping):
        raise ActionError(f"actions must be a dict {{agent: action}}, got {type(actions).__name__}")
    live = set(agents)
    extra = [a for a in actions if a not in live]
    if extra:
        raise ActionError(f"actions given for agent(s) {extra!r} that are not alive now "
                          f"(done earlier, or not in this episode); live agents: {agents}")
    missing = [a for a in agents if a not in actions]
    if missing:
        raise ActionError(f"no action for live agent(s) {missing}")
    values = [actions[a] for a in agents]
    # the common case, plain ints in range (what samplers and policies give), in one pass; anything
    # else goes through the checks below, which name the culprit
    if all(type(v) in _PLAIN_INTS and 0 <= v < n_actions for v in values):
        return np.array(values, dtype=np.int64)
    raw = np.empty(len(agents), dtype=np.int64)
    for k, agent in enumerate(agents):
        value = actions[agent]
        if isinstance(value, np.ndarray) and value.shape == ():
            value = value[()]
        if isinstance(value, (bool, np.bool_)) or not isinstance(value, (int, np.integer)):
            raise ActionError(f"action for {agent} must be an integer in [0, {n_actions}), got "
                              f"{value!r} ({type(value).__name__})")
        if not 0 <= value < n_actions:
            raise ActionError(f"action for {agent} must be in [0, {n_actions}), got {value!r}")
        raw[k] = int(value)
    return raw
