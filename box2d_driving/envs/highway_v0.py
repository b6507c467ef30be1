"""``highway-v0``: one-way highway, cars of different acceleration ratings (see :mod:`box2d_driving.envs.highway`)."""

from box2d_driving.envs.pettingzoo_style import module_functions
from box2d_driving.envs.highway import HighwayConfig, HighwayEnv

__all__ = ["HighwayConfig", "HighwayEnv", "env", "parallel_env", "raw_env"]

parallel_env, env, raw_env = module_functions("highway-v0")
