"""Scripted policies usable wherever a trained policy is: ``act(observations) -> actions``.

* :class:`RandomPolicy`: uniform random actions (seeded).
* :class:`LightRulePolicy`: the crude hand rule for the intersection: brake hard while the light
  shows 0.5 or 1.0 (yellow or red in the default colours), otherwise accelerate fully. A reference
  for what obeying the lights achieves, and a check on the metric code.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from box2d_driving.road.lights import RED, YELLOW


class RandomPolicy:
    """Uniform random actions from each agent's action space."""

    def __init__(self, env: Any, seed: int | None = None) -> None:
        self.env = env
        self.rng = np.random.default_rng(seed)

    def act(self, observations: dict[str, np.ndarray]) -> dict[str, int]:
        return {a: int(self.rng.integers(self.env.action_space(a).n)) for a in observations}


class LightRulePolicy:
    """Brake while the light seen is in ``stop_values``, else full acceleration (bit 0)."""

    def __init__(self, env: Any, stop_values: tuple[float, ...] = (YELLOW, RED)) -> None:
        layout = env.observation_layout
        self._light = layout.satnav.start + (layout.history - 1) * layout.n_satnav + layout.field("light")
        self._stop_values = np.asarray(stop_values)
        self._brake = 0
        self._go = len(env.config.accelerations) - 1

    def act(self, observations: dict[str, np.ndarray]) -> dict[str, int]:
        return {a: self._brake if np.any(np.isclose(o[self._light], self._stop_values)) else self._go
                for a, o in observations.items()}


SCRIPTED = {"random": RandomPolicy, "rule": LightRulePolicy}


def make_policy(name: str, env: Any, seed: int | None = None):
    """A scripted policy by name (``random`` or ``rule``)."""
    if name == "random":
        return RandomPolicy(env, seed)
    if name == "rule":
        return LightRulePolicy(env)
    raise ValueError(f"unknown policy {name!r}; scripted policies: {', '.join(SCRIPTED)}")
