"""Scenarios as records: everything the package knows about one scenario, registered once.

A :class:`Scenario` names its env id, the env class, and what evaluating it means: the rule
metrics its learning curves follow and its sweep summaries keep, the counts its results figures
draw, its full evaluation report, the scripted drivers that make sense as its baselines, its
single-agent Gymnasium id and the ``box2d-driving train`` behaviour that trains it. The env ids
``make`` knows, the CLI's list, the Gymnasium ids, the evaluation reports, the curve metrics and
the figure counts are all read from these records.

Register your own scenario once::

    from box2d_driving.scenarios import Scenario, register

    register(Scenario("crossing-v0", CrossingEnv, "unsignalled crossing", rule_metrics=my_metric,
                      curve_metrics=("yield_share",)))
    env = box2d_driving.make("crossing-v0", num_cars=4)

``register`` reaches this process (and the worker processes it forks). An installed package
reaches every process and the CLI by naming its record in the entry-point group
:data:`ENTRY_POINTS` (``box2d_driving.scenarios``), e.g. in its ``setup.cfg``::

    [options.entry_points]
    box2d_driving.scenarios =
        crossing = my_package.crossing:SCENARIO

Functions and classes may be given as ``"module:name"`` strings: they are imported on first use,
so listing the scenarios stays cheap.
"""

from __future__ import annotations

from importlib.metadata import entry_points

import gymnasium as gym

from box2d_driving.config import ConfigError
from box2d_driving.envs.catalog import SHIPPED
from box2d_driving.scenario import Scenario, SingleAgent

__all__ = ["ENTRY_POINTS", "Scenario", "SingleAgent", "register", "scenario", "scenarios"]

ENTRY_POINTS = "box2d_driving.scenarios"

_REGISTERED: dict[str, Scenario] = {}
_LOADED_ENTRY_POINTS = False


def register(scenario: Scenario, replace: bool = False) -> Scenario:
    """Add ``scenario`` (and its single-agent Gymnasium id, if any) to the registry. An id that is
    taken is a :class:`ConfigError` unless ``replace`` (the same record again is a no-op)."""
    if not isinstance(scenario, Scenario):
        raise ConfigError(f"register: expected a Scenario, got {type(scenario).__name__}")
    from box2d_driving.policies.scripted import SCRIPTED  # here: the policies import the registry

    unknown = [b for b in scenario.baselines if b not in SCRIPTED]
    if unknown:
        raise ConfigError(f"register: {scenario.env_id}'s baselines {unknown} are not scripted policies "
                          f"({', '.join(SCRIPTED)})")
    return _add(scenario, replace)


def _add(scenario: Scenario, replace: bool = False) -> Scenario:
    """:func:`register` without its checks of the names a record uses (the shipped records:
    tested, and registered while the policies cannot be imported yet)."""
    old = _REGISTERED.get(scenario.env_id)
    if old is not None and old != scenario and not replace:
        raise ConfigError(f"register: env id {scenario.env_id!r} is taken (by {old.env!r}); pass replace=True "
                          "to replace it")
    _REGISTERED[scenario.env_id] = scenario
    _register_gym_id(scenario, replace=replace)
    return scenario


def _register_gym_id(scenario: Scenario, replace: bool = False) -> None:
    """Register ``scenario``'s single-agent Gymnasium id, if it has one (the env is
    :class:`box2d_driving.single_agent.SingleAgentDrivingEnv`); an id Gymnasium has already is
    kept unless ``replace``."""
    spec = scenario.single_agent
    if spec is None:
        return
    if spec.gym_id in gym.registry:
        if not replace:
            return
        del gym.registry[spec.gym_id]
    gym.register(id=spec.gym_id, entry_point="box2d_driving.single_agent:SingleAgentDrivingEnv",
                 kwargs={"env_id": scenario.env_id, "shipped": spec.background, "fallback": spec.fallback})


def _load_entry_points() -> None:
    """Register the records installed packages name in :data:`ENTRY_POINTS` (once)."""
    global _LOADED_ENTRY_POINTS
    if _LOADED_ENTRY_POINTS:
        return
    _LOADED_ENTRY_POINTS = True
    for ep in entry_points(group=ENTRY_POINTS):
        try:
            found = ep.load()
        except Exception as exc:  # one broken plug-in names itself, and leaves the others working
            raise ConfigError(f"scenario entry point {ep.name!r} ({ep.value}) cannot be loaded: {exc}") from exc
        if found.env_id not in _REGISTERED:
            register(found)


def scenarios() -> dict[str, Scenario]:
    """Every registered scenario by env id: the shipped ones first, then entry points', then
    those registered in this process."""
    _load_entry_points()
    return dict(_REGISTERED)


def scenario(env_id: str) -> Scenario:
    """The record of ``env_id``; :class:`ConfigError` naming the registered ids otherwise."""
    known = scenarios()
    if env_id not in known:
        raise ConfigError(f"unknown env id {env_id!r}; registered: {', '.join(known)}")
    return known[env_id]


for _shipped in SHIPPED:
    _add(_shipped)
