"""Metrics that measure each road rule from recorded rollouts (SPEC 6)."""
