"""``intersection-spline-v0``: signalled four-way junction, each car picks its own spline path
(lanes) (see :mod:`box2d_driving.envs.intersection_spline`)."""

from box2d_driving.envs.pettingzoo_style import module_functions
from box2d_driving.envs.intersection_spline import IntersectionSplineConfig, IntersectionSplineEnv

__all__ = ["IntersectionSplineConfig", "IntersectionSplineEnv", "env", "parallel_env", "raw_env"]

parallel_env, env, raw_env = module_functions("intersection-spline-v0")
