"""One readable script per behaviour, each configured by a dataclass (CleanRL style):
``traffic_lights``, ``crosswalk``, ``lanes``, ``fast_lanes``, ``real_junction`` (the commands
``box2d-driving train NAME``), their shared arguments and run logic (``scripts``), and
``single_agent_ppo`` (plain SB3 PPO on a single-agent Gymnasium env).

Imports :mod:`training.trainers` and the packages below it.
"""
