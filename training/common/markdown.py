"""Markdown pieces the results page, the README table and the curve readings share."""

from __future__ import annotations

__all__ = ["anchor", "row", "separator"]


def row(cells: list[str]) -> str:
    """One Markdown table row; a ``|`` inside a cell (as in ``|Pearson|``) is escaped, else it would
    split the cell."""
    return "| " + " | ".join(c.replace("|", "\\|") for c in cells) + " |"


def separator(columns: int) -> str:
    """The row under a Markdown table's header."""
    return "|" + "---|" * columns


def anchor(title: str) -> str:
    """The heading's link anchor as GitHub makes it (lower case, punctuation dropped, spaces to -)."""
    return "".join(c for c in title.lower() if c.isalnum() or c in " -_").replace(" ", "-")
