"""Grids of settings x training seeds on Ray Tune (``box2d-driving sweep``): the grid and its
checks (``spec``), the Tune driver with one trainable per trial (``sweep``) and the per-trial
summaries the results page is computed from (``summary``), and ``box2d-driving curve``, the
learning curves of a run or of every trial of a sweep on selection seeds (``curves``).

Imports :mod:`training.behaviours`, :mod:`training.evaluation` and the packages below them.
"""
