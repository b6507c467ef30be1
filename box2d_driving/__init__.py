"""box2d-driving: multi-agent Box2D driving worlds in which road rules emerge.

Quick start::

    import box2d_driving
    env = box2d_driving.make("intersection-v0", num_cars=4, lidar_noise=0.25)
    observations, infos = env.reset(seed=0)

Single-agent Gymnasium envs (the learner drives one car, the others a background policy)::

    import gymnasium as gym
    env = gym.make("box2d_driving/Intersection-v0")

Train and load policies (training needs the train extra)::

    box2d_driving.train("intersection-v0", "runs/lights", decisions=200_000, env={"num_cars": 4})
    policy = box2d_driving.load_policy("runs/lights")            # numpy; backend="torch" for SB3's
"""

__version__ = "0.1.0"

from pathlib import Path
from typing import Any, Union

from box2d_driving.config import ConfigError, DrivingConfig
from box2d_driving.envs.actions import ActionError
from box2d_driving.registry import make, registry
from box2d_driving.single_agent import register_single_agent_envs

register_single_agent_envs()  # gymnasium.make("box2d_driving/Intersection-v0") and the others



def train(env_id: str, out: Union[str, Path], *, decisions: int, **kwargs: Any) -> dict[str, Any]:
    """Train parameter-shared PPO with the centralised critic on ``env_id`` (any registered id,
    your own scenarios included) into the run folder ``out``, for ``decisions`` slot-decisions;
    ``env={...}`` holds env config overrides, ``seed=``, ``resume=`` and any training setting
    (``batch_decisions``, ``n_envs``, ...) may follow. Needs the train extra. Returns the last
    update's statistics."""
    from box2d_driving.plugins import api

    return api("train")(env_id, out, decisions=decisions, **kwargs)


def load_policy(path: Union[str, Path], backend: str = "numpy", deterministic: bool = True) -> Any:
    """A trained policy (a run folder, its ``.safetensors`` file or a shipped policy's name) with
    ``act(observations) -> actions`` and ``make_env()``: run with numpy (``backend="numpy"``, the
    base install) or with torch and SB3 (``"torch"``, the train extra); both give the same actions.
    ``backend="sb3"`` gives a ``stable_baselines3.PPO`` instead (``predict``, ``learn``, ``save``;
    built from the run's config and weights, nothing unpickled; its class is a subclass whose
    rollout loop overlaps env workers and learner, same rollouts as SB3's)."""
    if backend == "numpy":
        from box2d_driving.policies import load_trained

        return load_trained(path, deterministic=deterministic)
    if backend in ("torch", "sb3"):
        from box2d_driving.plugins import api

        if backend == "sb3":
            return api("load_ppo")(path)
        return api("load_policy")(path, deterministic=deterministic)
    raise ConfigError(f"load_policy: backend must be 'numpy', 'torch' or 'sb3', got {backend!r}")


__all__ = ["ActionError", "ConfigError", "DrivingConfig", "load_policy", "make", "registry", "train",
           "__version__"]
