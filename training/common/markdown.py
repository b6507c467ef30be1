"""Markdown pieces the results page, the README table and the curve readings share."""

from __future__ import annotations

__all__ = ["all_of", "anchor", "row", "separator"]


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


def all_of(n: int, singular: str, plural: str) -> str:
    """Every one of ``n`` things in words: "its seed" (1), "both seeds" (2), "all 3 seeds" (3 or more).

    English says "both" of two; "all 2 seeds" reads like a template, which the results page is not."""
    if n < 1:
        raise ValueError(f"all_of needs at least one {singular}, got n = {n}")
    return f"its {singular}" if n == 1 else f"both {plural}" if n == 2 else f"all {n} {plural}"
