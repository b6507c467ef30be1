"""Metrics that measure each road rule from recorded rollouts; what each measures: ``docs/results.md``."""
