"""The paper's own simulator and trainer (sdriving 0.1.0) run beside ours: ``box2d-driving original``.

The original commands as typed settings (``commands``), the command itself (``cli``), the same
scripted drivers in both worlds scored by one metric code (``compare``), an original actor as a
policy of ours and back (``export``), and the script that runs
inside sdriving's own virtual environment (``sdriving_worker.py``: its trainer in one process,
resumable; its world's rollouts as our table). Nothing here imports sdriving.

Imports the layers below it (:mod:`training.common`, the trainer's settings and presets); only
:mod:`training.results` imports it.
"""
