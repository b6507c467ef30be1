"""The README's results table (``box2d-driving reproduce --readme README.md``): the headline
grid points marked ``in_readme`` (the largest run of each of the paper's claims) over training
seeds, written between two marker lines of the README so that the rest of it is left as it is."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from training.common.markdown import anchor, row, separator
from training.results.data import ResultsError
from training.results.matching import group_at
from training.results.sections import SECTIONS
from box2d_driving.metrics.stats import Estimate

__all__ = ["README_END", "README_START", "readme_table", "readme_text", "update_readme"]


README_START = "<!-- results over training seeds: written by box2d-driving reproduce --readme -->"
README_END = "<!-- end of results over training seeds -->"


def readme_table(summaries: list[dict[str, Any]], page: str = "docs/results.md", every_headline: bool = False) -> str:
    """The README's results table: the headlines marked ``in_readme`` as mean ± 95 % half-width over
    training seeds, with the number of seeds and a link to the rule's section of ``page`` (where
    every other headline and grid point is); with ``every_headline``, every rule's headlines (the
    results page's own table, ``page=""`` for links within it)."""
    header = ["rule", "setting", "ours on report episodes: mean ± 95 % half-width over training seeds", "seeds",
              "details"]
    lines = [row(header), separator(len(header))]
    for section in SECTIONS:
        labels = dict(section.metrics)
        for h in (h for h in section.headlines if h.in_readme or every_headline):
            g = group_at(section, summaries, list(h.metrics), h.point)
            if g is not None:
                result = "; ".join(f"{labels.get(m, m)} {_headline_value(g.estimates[m])}" for m in h.metrics)
                seeds = str(len(g.seeds))
            else:
                result, seeds = "not run yet", "0"
            lines.append(row([h.rule, h.setting, result, seeds, f"[{section.title}]({page}#{anchor(section.title)})"]))
    return "\n".join(lines)


def _headline_value(e: Estimate) -> str:
    if e.n == 0:
        return "n/a"
    return e.format() if e.low is not None else f"{e.mean:.3f}"  # the seeds column says "1"


def readme_text(path: Path) -> str:
    """The README's text; :class:`ResultsError` unless it has the two result markers in order."""
    try:
        text = Path(path).read_text()
    except OSError as exc:
        raise ResultsError(f"--readme {path}: {exc.strerror}") from None
    if (text.count(README_START) != 1 or text.count(README_END) != 1
            or text.index(README_START) > text.index(README_END)):
        raise ResultsError(f"--readme {path}: needs one line {README_START!r} and, after it, one line {README_END!r}")
    return text


def update_readme(path: Path, table: str) -> None:
    """Replace the text between the README's two result markers with ``table``."""
    head, rest = readme_text(path).split(README_START)
    tail = rest.split(README_END)[1]
    tmp = Path(path).with_name(Path(path).name + ".partial")
    tmp.write_text(f"{head}{README_START}\n{table}\n{README_END}{tail}")
    tmp.replace(path)
