"""The training loops: one PPO run of a multi-agent scenario (``trainer``), the bilevel spline +
acceleration rounds (``bilevel``), and the training-throughput benchmark (``bench_train``,
``box2d-driving bench --train``).

Imports :mod:`training.common`, :mod:`training.ppo` and :mod:`training.runs`.
"""
