"""Evaluating trained policies on held-out episodes: the ``evaluate`` command and its report
(``reports``, ``plots``), the distributions a results page redraws (``figure_data``), learning
curves over a run's checkpoints (``checkpoint_curve``) and the communication study's table
(``communication_table``).

Imports :mod:`training.common` and :mod:`training.runs`; never the trainers.
"""
