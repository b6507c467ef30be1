"""The Markdown helpers, kept importable here (they live in :mod:`training.common.markdown`, low
enough for every trainer sub-package to use)."""

from training.common.markdown import all_of, anchor, row, separator

__all__ = ["all_of", "anchor", "row", "separator"]
