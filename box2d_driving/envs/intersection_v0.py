"""``intersection-v0``: signalled four-way junction, fixed straight tracks
(see :mod:`box2d_driving.envs.intersection`)."""

from box2d_driving.envs.pettingzoo_style import module_functions
from box2d_driving.envs.intersection import IntersectionConfig, IntersectionEnv

__all__ = ["IntersectionConfig", "IntersectionEnv", "env", "parallel_env", "raw_env"]

parallel_env, env, raw_env = module_functions("intersection-v0")
