"""Run a trained policy with numpy alone: ``load_trained(path).act(observations)``.

A run folder holds ``model.safetensors`` (the weights, see
:mod:`box2d_driving.policies.checkpoint_file`) and ``config.json`` (the env id and settings the
policy was trained with). A bilevel run (lanes, fast lanes) holds ``accel/`` (the acceleration
policy) and ``spline/`` (the path-choosing policy) beside one ``config.json``. Loading rebuilds the
actor from those two files and nothing else: no torch, no SB3 (the base install runs the shipped
policies, for instance as the background cars of the single-agent Gymnasium envs).
``box2d_driving.load_policy(path, backend="torch")`` (the train extra) gives the same actions
through torch.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Optional, Union

import numpy as np

from box2d_driving.policies.checkpoint_file import (CheckpointError, find_config, is_bilevel_run,
                                                    load_json_file, read_arrays, read_json)
from box2d_driving.policies.numpy_actor import DrivingActor, MlpActor, check_spline_hidden
from box2d_driving.policies.shipped import resolve_policy_path
from box2d_driving.registry import make


class RunPolicy:
    """What a policy loaded from a run folder offers, whatever computes its actions: the env it
    was trained on (:meth:`make_env`), its light convention (:attr:`stop_value`) and ``act``.
    Subclasses supply :meth:`actions` (and, for a bilevel run, :meth:`choose_paths`).

    Attributes:
        config: the run's ``config.json`` (for a bilevel run: its acceleration stage's).
        run_dir: the folder the policy was loaded from (its evaluation report, if any).
        deterministic: the most likely action (True) or one drawn from the policy.
        obs_dim: the length of the observation the actor reads.
        spline_policy: for a bilevel run, what picks each car's path; None otherwise.
    """

    def __init__(self, config: dict, run_dir: Optional[Path], obs_dim: int, deterministic: bool = True) -> None:
        self.config = config
        self.run_dir = run_dir
        self.obs_dim = obs_dim
        self.deterministic = deterministic
        self.spline_policy: Any = None

    @property
    def env_id(self) -> str:
        return self.config["env_id"]

    @property
    def env_overrides(self) -> dict:
        return dict(self.config["env_overrides"])

    @property
    def stop_value(self) -> Optional[float]:
        """The light value this policy stops on (0.0 or 1.0), from its evaluation report
        (``eval/metrics.json`` beside the checkpoint); None where unknown. The two light groups
        are symmetric, so training may settle on either value as "stop"."""
        if self.run_dir is None:
            return None
        for folder in (self.run_dir, self.run_dir.parent):  # a bilevel run keeps eval/ above accel/
            report = folder / "eval" / "metrics.json"
            if report.is_file():
                try:
                    value = load_json_file(report)
                except CheckpointError:
                    return None
                value = value.get("stop_value") if isinstance(value, dict) else None
                return float(value) if value in (0.0, 1.0) and not isinstance(value, bool) else None
        return None

    def actions(self, obs: np.ndarray) -> np.ndarray:
        """Actions ``(M,)`` int64 for own observations ``(M, obs_dim)``."""
        raise NotImplementedError

    def choose_paths(self, obs0: np.ndarray) -> np.ndarray:
        """Stage-0 actions ``(N, ...)`` for stage-0 observations ``(N, D0)`` (bilevel runs)."""
        raise NotImplementedError

    def act(self, observations: dict[str, np.ndarray]) -> dict[str, int]:
        if not observations:
            return {}
        agents = list(observations)
        obs = np.stack([np.asarray(observations[a], dtype=np.float32) for a in agents])
        if obs.shape[1] != self.obs_dim:
            raise ValueError(f"observation size {obs.shape[1]} does not match the policy's "
                             f"{self.obs_dim}: wrong env settings for this checkpoint?")
        return dict(zip(agents, self.actions(obs).tolist()))

    def make_env(self, **extra: Any):
        """A fresh env with the settings the policy was trained on (``extra`` overrides them).
        A rendering env draws the light value the policy stops on red (``render_stop_value``);
        a bilevel policy's env picks each car's path with its spline policy."""
        if extra.get("render_mode") is not None and "render_stop_value" not in extra \
                and self.stop_value is not None:
            extra["render_stop_value"] = self.stop_value
        env = make(self.env_id, **{**self.env_overrides, **extra})
        if self.spline_policy is not None:
            env.spline_policy = self.choose_paths
        return env


class NumpyPolicy(RunPolicy):
    """A trained actor run with numpy (the base install's loader: :func:`load_trained`).
    ``act(observations)`` maps ``{agent: obs}`` to ``{agent: action}``: the most likely action, or
    (``deterministic=False``) one drawn from the policy's distribution with ``seed``'s generator.
    The actor reads only each car's own observation; a bilevel run's ``spline_policy`` is an
    :class:`MlpActor`."""

    def __init__(self, actor: DrivingActor, config: dict, run_dir: Path, deterministic: bool = True,
                 seed: Optional[int] = None) -> None:
        super().__init__(config, run_dir, actor.obs_dim, deterministic)
        self.actor = actor
        self._rng = np.random.default_rng(seed)

    def actions(self, obs: np.ndarray) -> np.ndarray:
        logits = self.actor.logits(obs)
        if self.deterministic:
            return logits.argmax(axis=1).astype(np.int64)
        p = np.exp(logits - logits.max(axis=1, keepdims=True))
        cdf = np.cumsum(p / p.sum(axis=1, keepdims=True), axis=1)
        u = self._rng.random((len(cdf), 1))
        return np.minimum((cdf < u).sum(axis=1), cdf.shape[1] - 1).astype(np.int64)

    def choose_paths(self, obs0: np.ndarray) -> np.ndarray:
        return self.spline_policy(obs0)


# the numpy policy's name in earlier releases
TrainedPolicy = NumpyPolicy


def run_env(config: dict, where: Path):
    """The env a run's ``config`` (env id and overrides) names, or :class:`CheckpointError`
    naming ``where`` the config came from."""
    try:
        return make(config["env_id"], **config["env_overrides"])
    except (KeyError, TypeError, ValueError) as exc:
        raise CheckpointError(f"{where}: cannot rebuild the policy's env ({exc!r})") from None


def load_trained(path: Union[str, Path], deterministic: bool = True,
                 seed: Optional[int] = None) -> NumpyPolicy:
    """Load a checkpoint: a run folder (``model.safetensors`` + ``config.json``), the
    ``.safetensors`` file itself, or a bilevel run folder with ``accel/`` and ``spline/``, whose
    envs then pick their paths with the spline policy. Raises :class:`CheckpointError` (a
    ``ValueError``) naming the file for anything missing, unsafe (a pickled ``model.zip``) or
    malformed. A shipped policy may be given by name (``"traffic_lights_4cars_noise05"``, see
    :func:`~box2d_driving.policies.shipped.shipped_policies`)."""
    path = resolve_policy_path(path)
    if is_bilevel_run(path):
        policy = load_trained(path / "accel", deterministic, seed)
        policy.spline_policy = _spline_actor(path)
        return policy
    file, weights, _ = read_arrays(path)
    config_path = find_config(file)
    config = read_json(config_path)
    env = run_env(config, config_path)
    layout = env.observation_layout
    n_actions = int(env.action_space(env.possible_agents[0]).n)
    env.close()
    try:
        actor = DrivingActor(weights, layout.history, layout.n_rays, n_actions=n_actions)
    except ValueError as exc:
        raise CheckpointError(f"{file} does not fit {config_path}'s env ({exc})") from None
    if actor.obs_dim != layout.size:
        raise CheckpointError(f"{file} reads {actor.obs_dim} observation values, {config_path}'s env "
                              f"gives {layout.size}: another scenario's checkpoint?")
    return NumpyPolicy(actor, config, config_path.parent, deterministic, seed)


def _spline_actor(run: Path) -> MlpActor:
    """The greedy stage-0 (spline) actor of a bilevel run folder."""
    file, weights, _ = read_arrays(run / "spline")
    config = read_json(run / "config.json")
    try:
        env = run_env(config["accel"], run / "config.json")
        space, seen = env.spline_action_space, env.spline_observation_space
        declared = [int(h) for h in config.get("spline_hidden", (64, 64))]
    except (KeyError, TypeError, AttributeError, ValueError, OverflowError) as exc:
        raise CheckpointError(f"{run / 'config.json'}: cannot rebuild the spline policy ({exc!r})") from None
    env.close()
    check_spline_hidden(weights, declared, run / "config.json", file)
    try:
        return MlpActor(weights, space, len(declared), seen)
    except ValueError as exc:
        raise CheckpointError(f"{file} does not fit {run / 'config.json'}'s spline policy ({exc})") from None
