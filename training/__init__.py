"""Training: PPO with a centralised critic over a slot VecEnv, scripts, evaluation, inference.

Needs the ``train`` extra (``pip install -c constraints-cpu.txt -e ".[train]"``).
"""

from training.inference import TrainedPolicy, load_policy

__all__ = ["TrainedPolicy", "load_policy"]
