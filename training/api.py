"""The training package's Python functions that ``box2d_driving`` offers at its top level
(``box2d_driving.train``, ``box2d_driving.load_policy(..., backend="torch")``), plugged in through
the entry-point group ``box2d_driving.api`` so that user code never imports ``training`` by name
(a research folder's own ``training/`` package would shadow it)."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from typing import Any, Optional, Union

from training.trainers.trainer import RunError, TrainConfig

__all__ = ["load_policy", "load_ppo", "train"]


def train(env_id: str, out: Union[str, Path], *, decisions: int, env: Optional[dict] = None, seed: int = 0,
          resume: bool = False, **settings: Any) -> dict[str, Any]:
    """Train parameter-shared PPO with the centralised critic on ``env_id`` into the run folder
    ``out`` (``model.safetensors``, ``config.json``, progress logs; resumable with ``resume``).

    Args:
        env_id: any registered env id, your own scenarios included.
        decisions: slot-decisions to train for (one per car slot per env step).
        env: env config overrides (``{"num_cars": 4}``).
        seed: seeds PPO and the envs.
        **settings: any other field of :class:`training.trainers.trainer.TrainConfig`
            (``batch_decisions``, ``n_envs``, ``ent_coef``, ...).

    Returns the last update's statistics. A setting that is not a field is a :class:`RunError`
    naming it and listing the fields.
    """
    fields = {f.name for f in dataclasses.fields(TrainConfig)} - {"env_id", "env_overrides", "timesteps", "seed"}
    unknown = sorted(set(settings) - fields)
    if unknown:
        raise RunError(f"train: unknown setting(s) {', '.join(unknown)}; settings: {', '.join(sorted(fields))}")
    from training.trainers.trainer import train as run

    config = TrainConfig(env_id=env_id, env_overrides=dict(env or {}), timesteps=decisions, seed=seed, **settings)
    return run(config, Path(out), resume=resume)


def load_policy(path: Union[str, Path], deterministic: bool = True) -> Any:
    """A trained policy with torch and SB3 (:func:`training.runs.inference.load_policy`): its
    ``act(observations)``, ``make_env()`` and ``env_id``."""
    from training.runs.inference import load_policy as load

    return load(path, deterministic=deterministic)


def load_ppo(path: Union[str, Path]) -> Any:
    """A plain ``stable_baselines3.PPO`` of a run folder or a shipped policy, by path or name
    (:func:`training.trainers.trainer.load_ppo`)."""
    from box2d_driving.policies.shipped import resolve_policy_path
    from training.trainers.trainer import load_ppo as load

    return load(resolve_policy_path(path))
