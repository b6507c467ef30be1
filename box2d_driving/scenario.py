"""The record of one scenario (:class:`Scenario`); :mod:`box2d_driving.scenarios` registers
and finds them."""

from __future__ import annotations

import importlib
from dataclasses import dataclass, field
from typing import Any, Callable, Optional, Union

from box2d_driving.config import ConfigError
from box2d_driving.metrics.rules import OUTCOMES, outcomes

Ref = Union[str, Callable[..., Any]]  # a callable or class, or its "module:name"


@dataclass(frozen=True)
class SingleAgent:
    """The scenario as a single-agent Gymnasium env: the learner drives ``car_0``, a background
    policy the others (:mod:`box2d_driving.single_agent`).

    Attributes:
        gym_id: the Gymnasium id (``box2d_driving/Intersection-v0``).
        background: the shipped policy (a folder of ``assets/policies``) that drives the other
            cars, or None.
        fallback: the scripted policy that drives them where no shipped policy can be loaded.
    """

    gym_id: str
    background: Optional[str] = None
    fallback: str = "rule"


@dataclass(frozen=True)
class Scenario:
    """One scenario, as every part of the package sees it.

    Attributes:
        env_id: the versioned id ``make`` takes (``intersection-v0``).
        env: the :class:`~box2d_driving.envs.base.DrivingEnv` subclass (or its ``"module:Class"``);
            its config fields are the ids' overrides.
        description: one line for listings.
        rule_metrics: ``(rollout table, env config) -> {name: value}``: the scenario's rule
            measured on a block of episodes (beside success and collisions, which every scenario
            gets). None: outcomes only.
        curve_metrics: the names ``rule_metrics`` always returns, in the order a learning curve and
            a summary list them (it may return more, e.g. only with an option on).
        figure_data: ``(rollout table, env config) -> {name: counts}``, the distributions a
            results page draws, in fixed bins (:mod:`box2d_driving.metrics.figure_counts`); None:
            none.
        report: ``"module:function"`` of the full evaluation report (metrics and plots, run by
            ``box2d-driving evaluate``; the shipped scenarios' live in the training package).
            None: the outcomes, ``rule_metrics`` and the collision breakdown.
        baselines: scripted policies that are meaningful drivers of this scenario
            (:data:`box2d_driving.policies.SCRIPTED`).
        single_agent: the single-agent Gymnasium version, or None.
        trainer: the ``box2d-driving train`` behaviour that trains it, or None.
    """

    env_id: str
    env: Ref
    description: str
    rule_metrics: Optional[Ref] = None
    curve_metrics: tuple[str, ...] = ()
    figure_data: Optional[Ref] = None
    report: Optional[str] = None
    baselines: tuple[str, ...] = ("random", "full-throttle")
    single_agent: Optional[SingleAgent] = None
    trainer: Optional[str] = None
    _resolved: dict = field(default_factory=dict, init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        if not isinstance(self.env_id, str) or not self.env_id.endswith(tuple(f"-v{k}" for k in range(10))):
            raise ConfigError(f"Scenario: env_id must be a versioned name such as 'crossing-v0', got {self.env_id!r}")
        for name in ("env", "rule_metrics", "figure_data", "report"):
            value = getattr(self, name)
            if value is not None and not callable(value) and not (isinstance(value, str) and ":" in value):
                raise ConfigError(f"Scenario {self.env_id}: {name} must be a callable or 'module:name', got {value!r}")
        if self.curve_metrics and self.rule_metrics is None:
            raise ConfigError(f"Scenario {self.env_id}: curve_metrics {self.curve_metrics} need rule_metrics")
        object.__setattr__(self, "curve_metrics", tuple(self.curve_metrics))
        object.__setattr__(self, "baselines", tuple(self.baselines))

    def resolve(self, name: str) -> Any:
        """The attribute ``name``, imported on first use where it was given as ``"module:name"``."""
        value = getattr(self, name)
        if not isinstance(value, str):
            return value
        if name not in self._resolved:
            module, _, attr = value.partition(":")
            try:
                self._resolved[name] = getattr(importlib.import_module(module), attr)
            except (ImportError, AttributeError) as exc:
                raise ConfigError(f"scenario {self.env_id}: {name} {value!r} cannot be imported ({exc})") from None
        return self._resolved[name]

    @property
    def env_class(self) -> type:
        """The env class."""
        return self.resolve("env")

    def parallel_env(self, **overrides: Any) -> Any:
        """The parallel env; ``overrides`` are fields of its config."""
        return self.env_class(**overrides)

    def aec_env(self, **overrides: Any) -> Any:
        """The AEC (turn-based) view of :meth:`parallel_env`, with PettingZoo's order checks."""
        from box2d_driving.envs import to_aec

        return to_aec(self.parallel_env(**overrides))

    def curve(self) -> tuple[str, ...]:
        """The metrics a learning curve follows: success and collisions, then ``curve_metrics``."""
        return OUTCOMES + self.curve_metrics

    def measure(self, table: dict, config: Any) -> dict[str, float]:
        """Success and collision rates and ``rule_metrics`` of one block of episodes."""
        out = outcomes(table)
        if self.rule_metrics is not None:
            out.update(self.resolve("rule_metrics")(table, config))
        return out

    def figures(self, table: dict, config: Any) -> dict[str, Any]:
        """``figure_data`` of one block of episodes ({} where the scenario draws none)."""
        return {} if self.figure_data is None else dict(self.resolve("figure_data")(table, config))
