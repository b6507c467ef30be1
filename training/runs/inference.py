"""Load a trained policy and drive a ParallelEnv directly: ``load_policy(path).act(obs)``.

Loading never unpickles: the network is rebuilt from the run's ``config.json`` and its weights are
read from ``model.safetensors`` (see ``training/runs/checkpoint.py``)."""

from __future__ import annotations

from pathlib import Path
from typing import Any, Union

import numpy as np
import torch as th

from box2d_driving.policies.checkpoint_file import find_config, is_bilevel_run, read_json
from box2d_driving.policies.trained import RunPolicy, run_env
from box2d_driving.policies.numpy_actor import check_spline_hidden
from box2d_driving.policies.shipped import resolve_policy_path
from training.runs.checkpoint import CheckpointError, load_policy_weights, read_checkpoint


class TorchPolicy(RunPolicy):
    """A trained actor run with torch (the trainer's network itself). ``act(observations)`` maps
    ``{agent: obs}`` to ``{agent: action}``; deterministic (most likely action) unless
    ``deterministic=False``. The actor needs only each car's own observation, so no training
    wrapper is involved. :func:`box2d_driving.policies.load_trained` gives the same actions with
    numpy alone."""

    def __init__(self, policy: Any, config: dict, deterministic: bool = True) -> None:
        super().__init__(config, None, policy.mlp_extractor.obs_dim, deterministic)
        self.policy = policy  # a training.ppo.policy.CTDEPolicy

    def attach_spline(self, spline_policy: Any) -> None:
        """Use ``spline_policy`` (a bilevel run's stage-0 SB3 policy) to pick each car's path;
        envs from :meth:`make_env` call it at every reset."""
        self.spline_policy = spline_policy

    def choose_paths(self, obs0: np.ndarray) -> np.ndarray:
        return self.spline_policy.predict(np.asarray(obs0, dtype=np.float32),
                                          deterministic=self.deterministic)[0]

    def actions(self, obs: np.ndarray) -> np.ndarray:
        return actor_actions(self.policy, obs, self.deterministic)


@th.no_grad()
def actor_actions(policy: Any, obs: np.ndarray, deterministic: bool = True) -> np.ndarray:
    """Actions ``(M,)`` of a CTDE policy's actor for own observations ``(M, D)`` (no team block)."""
    latent = policy.mlp_extractor.forward_actor(th.as_tensor(np.asarray(obs, dtype=np.float32), device=policy.device))
    dist = policy.action_dist.proba_distribution(action_logits=policy.action_net(latent))
    actions = dist.mode() if deterministic else dist.sample()
    return actions.cpu().numpy().astype(np.int64)


# the torch policy's name in earlier releases
TrainedPolicy = TorchPolicy


def load_policy(path: Union[str, Path], deterministic: bool = True) -> TorchPolicy:
    """Load a checkpoint: a run folder (``model.safetensors`` + ``config.json``), the
    ``.safetensors`` file itself, or a bilevel run folder with ``accel/`` and ``spline/``, whose
    envs then pick their paths with the spline policy. Raises :class:`CheckpointError` (a
    ``ValueError``) naming the file for anything missing, unsafe (a pickled ``model.zip``) or
    malformed. A shipped policy may be given by name, as to
    :func:`box2d_driving.policies.load_trained` (the same path resolution)."""
    path = resolve_policy_path(path)
    if is_bilevel_run(path):
        policy = load_policy(path / "accel", deterministic)
        policy.attach_spline(_load_spline_policy(path, path / "spline"))
        return policy
    ckpt = read_checkpoint(path)
    return _trained(ckpt, find_config(ckpt.path), deterministic)


def load_bilevel_round(run: Union[str, Path], round_: int, deterministic: bool = True) -> TorchPolicy:
    """A bilevel run's kept round ``round_``: its acceleration policy
    (``checkpoints/round_NNNN_accel.safetensors``) with that round's spline policy attached
    (``round_NNNN_spline.safetensors``), both as the run's configs shape them."""
    run = Path(run)
    stem = run / "checkpoints" / f"round_{round_:04d}"
    policy = _trained(read_checkpoint(Path(f"{stem}_accel.safetensors")), run / "accel" / "config.json", deterministic)
    policy.attach_spline(_load_spline_policy(run, Path(f"{stem}_spline.safetensors")))
    return policy


def _trained(ckpt: Any, config_path: Path, deterministic: bool) -> TorchPolicy:
    """The CTDE policy of checkpoint ``ckpt``, shaped by the run config at ``config_path``."""
    config = read_json(config_path)
    net = build_ctde_policy(config, config_path)
    load_policy_weights(net, ckpt, actor_only_ok=True)
    policy = TorchPolicy(net, config, deterministic)
    policy.run_dir = config_path.parent
    return policy


def build_ctde_policy(config: dict, where: Path) -> Any:
    """An untrained :class:`CTDEPolicy` shaped for the env and critic a run's config names."""
    from training.ppo.policy import CTDEPolicy, policy_kwargs_for
    from training.ppo.slots import slot_observation_space

    from training.ppo.policy import CRITICS, ENCODERS

    critic = config.get("critic", "mean")
    if critic not in CRITICS:
        raise CheckpointError(f"{where}: critic must be one of {CRITICS}, got {critic!r}")
    lidar_encoder = config.get("lidar_encoder", "relu")  # runs from before the choice had ours
    if lidar_encoder not in ENCODERS:
        raise CheckpointError(f"{where}: lidar_encoder must be one of {ENCODERS}, got {lidar_encoder!r}")
    env = run_env(config, where)
    agent = env.possible_agents[0]
    space = slot_observation_space(env.observation_space(agent), len(env.possible_agents))
    policy = CTDEPolicy(space, env.action_space(agent), lambda _: 0.0, **policy_kwargs_for(env, critic, lidar_encoder))
    env.close()
    return policy.eval()


def _load_spline_policy(run: Path, checkpoint: Path) -> Any:
    """The stage-0 (spline) policy of a bilevel run folder from ``checkpoint`` (its ``spline/``
    folder or a kept round's file), rebuilt from the run's ``config.json``."""
    import box2d_driving
    from stable_baselines3.common.policies import ActorCriticPolicy

    ckpt = read_checkpoint(checkpoint)
    config = read_json(run / "config.json")
    try:
        env = box2d_driving.make(config["accel"]["env_id"], **config["accel"]["env_overrides"])
        hidden = [int(h) for h in config.get("spline_hidden", (64, 64))]
        check_spline_hidden(ckpt.policy, hidden, run / "config.json", ckpt.path)
        policy = ActorCriticPolicy(env.spline_observation_space, env.spline_action_space,
                                   lambda _: 0.0, net_arch=hidden)
    except CheckpointError:
        raise
    except (KeyError, TypeError, ValueError, AttributeError, OverflowError) as exc:
        raise CheckpointError(f"{run / 'config.json'}: cannot rebuild the spline policy ({exc!r})") from None
    env.close()
    load_policy_weights(policy, ckpt, actor_only_ok=True)
    return policy.eval()
