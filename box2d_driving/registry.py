"""Versioned env ids: ``make(env_id, **overrides)`` and ``registry()``, read from the scenario
records (:mod:`box2d_driving.scenarios`; register your own there)."""

from __future__ import annotations

from typing import Any, Optional

from box2d_driving.compile_note import note_first_compile
from box2d_driving.presets import preset_overrides
from box2d_driving.scenarios import scenario, scenarios


def registry() -> dict[str, str]:
    """Registered env ids with one-line descriptions."""
    return {env_id: s.description for env_id, s in scenarios().items()}


def make(env_id: str, preset: Optional[str] = None, **overrides: Any):
    """Create the parallel env ``env_id`` with config ``overrides`` (e.g. ``num_cars=8``), on top
    of the named ``preset``'s values where one is given (``preset="paper"``: the world of the
    paper's own code; :mod:`box2d_driving.presets`)."""
    record = scenario(env_id)
    if preset is not None:
        overrides = {**preset_overrides(preset, env_id), **overrides}
    note_first_compile()  # a silent wait of up to 40 s on a fresh install otherwise
    return record.parallel_env(**overrides)
