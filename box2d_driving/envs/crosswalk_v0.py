"""``crosswalk-v0``: highway with a crosswalk and crossing pedestrians (see :mod:`box2d_driving.envs.crosswalk`)."""

from box2d_driving.envs.pettingzoo_style import module_functions
from box2d_driving.envs.crosswalk import CrosswalkConfig, CrosswalkEnv

__all__ = ["CrosswalkConfig", "CrosswalkEnv", "env", "parallel_env", "raw_env"]

parallel_env, env, raw_env = module_functions("crosswalk-v0")
