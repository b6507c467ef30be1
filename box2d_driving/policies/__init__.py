"""Policies that drive the cars of a ParallelEnv: ``policy.act(observations) -> actions``
(:class:`~box2d_driving.policies.protocol.Policy`).

* :mod:`~box2d_driving.policies.scripted`: hand-written drivers (random, full throttle, the light
  rule, the privileged pedestrian oracle), references for every metric.
* :mod:`~box2d_driving.policies.trained`: a trained checkpoint run with numpy alone
  (:func:`load_trained`, a :class:`NumpyPolicy`; the trainer's torch loader,
  ``box2d_driving.load_policy(path, backend="torch")``, gives a ``TorchPolicy`` with the same actions);
  :mod:`~box2d_driving.policies.numpy_actor` holds its networks and
  :mod:`~box2d_driving.policies.checkpoint_file` the safe file format.

This package imports nothing from the trainer (``training``), so the base install runs the
shipped policies.
"""

from box2d_driving.policies.checkpoint_file import CheckpointError
from box2d_driving.policies.scripted import (SCRIPTED, ConstantSpeedPolicy, FullThrottlePolicy, LightRulePolicy,
                                             PedestrianOraclePolicy, RandomPolicy, make_policy)
from box2d_driving.policies.protocol import Policy
from box2d_driving.policies.trained import NumpyPolicy, RunPolicy, TrainedPolicy, load_trained

__all__ = ["CheckpointError", "ConstantSpeedPolicy", "FullThrottlePolicy", "LightRulePolicy", "NumpyPolicy",
           "PedestrianOraclePolicy", "Policy", "RandomPolicy", "RunPolicy", "SCRIPTED", "TrainedPolicy", "load_trained",
           "make_policy"]
