"""A training run's files: checkpoints that cannot run code (``checkpoint``), loading a trained
policy into torch (``inference``), starting from a related run's weights (``weights``), the run
folder and its atomic writes (``run_dir``), progress logs and periodic checkpoints (``progress``),
and converting an old pickled ``model.zip`` of one's own (``convert_checkpoint``).

Imports :mod:`training.common` and :mod:`training.ppo`.
"""
