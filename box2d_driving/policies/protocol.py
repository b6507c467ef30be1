"""What drives cars: the one interface every policy here has, scripted or trained, numpy or torch.

``act`` maps each live car's observation (``{agent: obs}``, the agents of ``env.agents``) to its
action (``{agent: int}``); a policy keeps no reference to the env it drives unless it says so
(the privileged pedestrian oracle reads its env's world). ``record``, ``evaluate``, the single-agent
envs' background cars and the demo take any :class:`Policy`.
"""

from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np

__all__ = ["Policy"]


@runtime_checkable
class Policy(Protocol):
    """Anything with ``act(observations) -> actions`` (``isinstance(x, Policy)`` checks for it)."""

    def act(self, observations: dict[str, np.ndarray]) -> dict[str, int]:
        """The action of each car in ``observations`` (its agent name to its own observation)."""
        ...
