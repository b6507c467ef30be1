"""box2d-driving: multi-agent Box2D driving worlds in which road rules emerge.

Quick start::

    import box2d_driving
    env = box2d_driving.make("intersection-v0", num_cars=4, lidar_noise=0.25)
    observations, infos = env.reset(seed=0)

Single-agent Gymnasium envs (the learner drives one car, the others a background policy)::

    import gymnasium as gym
    env = gym.make("box2d_driving/Intersection-v0")
"""

__version__ = "0.1.0"

from box2d_driving.config import ConfigError, DrivingConfig
from box2d_driving.envs.actions import ActionError
from box2d_driving.registry import make, registry
from box2d_driving.single_agent import register_single_agent_envs

register_single_agent_envs()  # gymnasium.make("box2d_driving/Intersection-v0") and the others

__all__ = ["ActionError", "ConfigError", "DrivingConfig", "make", "registry", "__version__"]
