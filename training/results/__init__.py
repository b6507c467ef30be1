"""The results page (``box2d-driving reproduce``): reading the committed sweep summaries
(``data``), intervals and tests over training seeds (``stats``), what each rule's section
states (``statements``, which the ``sections`` name), its figures (``figures``), running every
rule's sweep (``run_all``) and writing ``docs/results.md`` and the README table (``reproduce``).

Imports :mod:`training.sweeps` and the packages below it; nothing imports it.
"""
