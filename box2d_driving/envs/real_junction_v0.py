"""``real-junction-v0``: real junctions from map files: lanes, connectors, real signals
(see :mod:`box2d_driving.envs.real_junction`)."""

from box2d_driving.envs.pettingzoo_style import module_functions
from box2d_driving.envs.real_junction import RealJunctionConfig, RealJunctionEnv

__all__ = ["RealJunctionConfig", "RealJunctionEnv", "env", "parallel_env", "raw_env"]

parallel_env, env, raw_env = module_functions("real-junction-v0")
