"""``highway-spline-v0``: one-way highway, each car picks its own lateral target (fast lanes)
(see :mod:`box2d_driving.envs.highway_spline`)."""

from box2d_driving.envs.pettingzoo_style import module_functions
from box2d_driving.envs.highway_spline import HighwaySplineConfig, HighwaySplineEnv

__all__ = ["HighwaySplineConfig", "HighwaySplineEnv", "env", "parallel_env", "raw_env"]

parallel_env, env, raw_env = module_functions("highway-spline-v0")
