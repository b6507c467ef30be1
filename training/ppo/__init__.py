"""PPO with a centralised critic, built from Stable-Baselines3's extension points: the actor and
critic network (``policy``, its LiDAR ``encoder``), the masked rollout buffer (``buffer``), the
one-slot-per-car vector env over SuperSuit (``vec_env``), the spline stage's one-step bandit
(``bandit``) and the greedy spline picker worker processes share (``shared_policy``).

Imports ``box2d_driving``, SB3, SuperSuit, torch and :mod:`training.common`; nothing above it.
"""
