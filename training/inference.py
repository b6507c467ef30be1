"""Load a trained policy and drive a ParallelEnv directly: ``load_policy(path).act(obs)``."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Union

import numpy as np
import torch as th


class TrainedPolicy:
    """A trained actor. ``act(observations)`` maps ``{agent: obs}`` to ``{agent: action}``;
    deterministic (most likely action) unless ``deterministic=False``. The actor needs only each
    car's own observation, so no training wrapper is involved."""

    def __init__(self, model: Any, config: dict, deterministic: bool = True) -> None:
        self.model = model
        self.config = config
        self.deterministic = deterministic
        self.policy = model.policy
        self.obs_dim = self.policy.mlp_extractor.obs_dim
        self.spline_model: Any = None

    def attach_spline(self, spline_model: Any) -> None:
        """Use ``spline_model`` (a bilevel run's stage-0 PPO) to pick each car's path; envs from
        :meth:`make_env` call it at every reset."""
        self.spline_model = spline_model

    def choose_paths(self, obs0: np.ndarray) -> np.ndarray:
        """Stage-0 actions ``(N, ...)`` for stage-0 observations ``(N, D0)``."""
        return self.spline_model.policy.predict(np.asarray(obs0, dtype=np.float32),
                                                deterministic=self.deterministic)[0]

    @property
    def env_id(self) -> str:
        return self.config["env_id"]

    @property
    def env_overrides(self) -> dict:
        return dict(self.config["env_overrides"])

    def make_env(self, **extra: Any):
        """A fresh env with the settings the policy was trained on (``extra`` overrides them)."""
        import box2d_driving

        env = box2d_driving.make(self.env_id, **{**self.env_overrides, **extra})
        if self.spline_model is not None:
            env.spline_policy = self.choose_paths
        return env

    @th.no_grad()
    def act(self, observations: dict[str, np.ndarray]) -> dict[str, int]:
        if not observations:
            return {}
        agents = list(observations)
        obs = np.stack([np.asarray(observations[a], dtype=np.float32) for a in agents])
        if obs.shape[1] != self.obs_dim:
            raise ValueError(f"observation size {obs.shape[1]} does not match the policy's "
                             f"{self.obs_dim}: wrong env settings for this checkpoint?")
        return dict(zip(agents, actor_actions(self.policy, obs, self.deterministic).tolist()))


@th.no_grad()
def actor_actions(policy: Any, obs: np.ndarray, deterministic: bool = True) -> np.ndarray:
    """Actions ``(M,)`` of a CTDE policy's actor for own observations ``(M, D)`` (no team block)."""
    latent = policy.mlp_extractor.forward_actor(th.as_tensor(np.asarray(obs, dtype=np.float32)))
    dist = policy.action_dist.proba_distribution(action_logits=policy.action_net(latent))
    actions = dist.mode() if deterministic else dist.sample()
    return actions.cpu().numpy().astype(np.int64)


def load_policy(path: Union[str, Path], deterministic: bool = True) -> TrainedPolicy:
    """Load a checkpoint (``model.zip`` or a run folder containing it, with its ``config.json``;
    or a bilevel run folder with ``accel/`` and ``spline/``, whose envs then pick their paths with
    the spline policy)."""
    from stable_baselines3 import PPO

    path = Path(path)
    if path.is_dir() and (path / "spline" / "model.zip").exists() and (path / "accel").is_dir():
        policy = load_policy(path / "accel", deterministic)
        try:
            policy.attach_spline(PPO.load(path / "spline" / "model.zip", device="cpu"))
        except Exception as exc:
            raise ValueError(f"cannot load spline checkpoint {path / 'spline' / 'model.zip'}: {exc}") from exc
        return policy
    model_path = path / "model.zip" if path.is_dir() else path
    if not model_path.exists():
        raise FileNotFoundError(f"no checkpoint at {model_path}")
    config_path = _find_config(model_path)
    try:
        config = json.loads(config_path.read_text())
        model = PPO.load(model_path, device="cpu")
    except Exception as exc:  # corrupt zip, wrong format, incompatible policy class
        raise ValueError(f"cannot load checkpoint {model_path}: {exc}") from exc
    if not hasattr(model.policy.mlp_extractor, "forward_actor") or not hasattr(model.policy.mlp_extractor, "obs_dim"):
        raise ValueError(f"{model_path} is not a box2d-driving CTDE policy checkpoint")
    return TrainedPolicy(model, config, deterministic)


def _find_config(model_path: Path) -> Path:
    for folder in (model_path.parent, model_path.parent.parent):
        if (folder / "config.json").exists():
            return folder / "config.json"
    raise FileNotFoundError(f"no config.json next to {model_path} or in its parent folder")
