"""The paper's own simulator and trainer (sdriving 0.1.0) run beside ours: ``box2d-driving original``.

sdriving lives in a virtual environment of its own (``box2d-driving original setup``);
``sdriving_worker.py`` runs there, and nothing here imports sdriving.
"""
