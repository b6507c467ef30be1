"""What one rule on the results page is (:class:`Section`) and its rows in the README's results
table (:class:`Headline`); the rules themselves are listed in :mod:`training.results.sections`."""

from __future__ import annotations

import shlex
from dataclasses import dataclass
from functools import cached_property
from pathlib import Path
from typing import Any, Callable, Optional

from training.results.data import Baseline, Group, Metric, PaperValue
from training.results.figures import Figure
from training.results.statements import Statement

__all__ = ["IN_GRID", "Headline", "Section"]

# a ``Section.match`` value: the option is one the sweep varies on its grid (not a fixed value)
IN_GRID = "(grid)"


@dataclass(frozen=True)
class Headline:
    """A headline of a rule: one grid point and the metrics shown; the README's results table shows
    the headlines marked ``in_readme`` (a few lines: the largest run of each of the paper's claims).

    Attributes:
        rule: what the row shows, in words.
        setting: the scenario and grid point, in words.
        point: grid values (as typed in the sweep's ``--grid``) the row's trials have.
        metrics: metric columns shown, labelled as in the section's table.
        in_readme: a row of the README's short table (otherwise only on the results page).
    """

    rule: str
    setting: str
    point: tuple[tuple[str, str], ...] = ()
    metrics: tuple[Metric, ...] = ()
    in_readme: bool = False


@dataclass(frozen=True)
class Section:
    """One rule on the page.

    Attributes:
        key: anchor and figure file stem.
        title: heading.
        behaviour: the sweep behaviour that measures it.
        match: fixed training options a sweep must have for this section (e.g. communication on);
            the value ``IN_GRID``: an option the sweep's grid varies.
        metrics: (metric column, label) shown in the table.
        paper: the paper's result in words.
        command: the sweep that produces it (``box2d-driving sweep ... --out runs/sweep-NAME``).
        setting: what each trial trains, in words (shown above the table).
        paper_values: the paper's numbers to compare ours with.
        figure: draws the section's figure from the grouped estimates (None: table only).
        baseline: measures a scripted reference driver on a summary's report episodes, for the
            section's statements and figure (the lights: a light-blind driver); None: none.
        statements: the section's own plain statements of what the intervals say against the
            paper's claim (beside the comparisons every section gets: with ``paper_values``, with
            ``compare_with`` and the grid points not learnt).
        shipped: the shipped policy animated in the section (a folder in assets/policies).
        gif_size: the animation's frame size in pixels.
        headlines: its headline grid points (those marked ``in_readme`` are the README's rows).
        compare_with: (another section's key, its grid point) whose trials this section's are set
            against in a statement (same metrics, intervals apart or not).
        paper_budget: what the paper's own runs of this rule trained (from the original code's
            experiment list), shown beside ours; empty where we do not know it.
        paper_joint_steps: joint env steps per trial of the paper's own runs of this rule (epochs x
            32,000; 0 where the page does not compare); with ``cars``, the claims table gives our
            trials' share of them.
        cars: cars per instance in this section's trials (0: they vary): our joint steps are our
            slot-decisions over it.
        seeds_before_look: the seeds planned before any look at the results (0 .. N-1); seeds from
            N on were added after an interim look and are marked in the tables. None: all planned.
        curve_extra: learning-curve columns (``box2d-driving curve``'s names) drawn and judged
            beside the table's plain metrics, for table metrics derived from a summary's figures
            (which a curve computes from its samples instead).
        joins: (another section's key, an option that section's sweeps fix and this section's grid
            varies): that section's trials join this section's table and statements as the grid
            points at their fixed value (e.g. a sweep at LiDAR noise 0 and 1.0 joined by the same
            settings' noise-0.5 trials, so the three levels are compared paired by seed). None: none.
        joins_differ: options the joined sweeps may fix at other values than this section's (the
            paper's budget per noise level: 75 epochs at noise 0.25-0.75, 50 at noise 1.0).
    """

    key: str
    title: str
    behaviour: str
    match: tuple[tuple[str, str], ...]
    metrics: tuple[tuple[Metric, str], ...]
    paper: str
    command: str
    setting: str = ""
    paper_values: tuple[PaperValue, ...] = ()
    figure: Optional[Figure] = None
    baseline: Optional[Callable[[dict[str, Any], list[Group]], Baseline]] = None
    statements: tuple[Statement, ...] = ()
    shipped: Optional[str] = None
    gif_size: tuple[int, int] = (320, 320)
    headlines: tuple[Headline, ...] = ()
    compare_with: Optional[tuple[str, tuple[tuple[str, str], ...]]] = None
    paper_budget: str = ""
    paper_joint_steps: int = 0
    cars: int = 0
    seeds_before_look: Optional[int] = None
    curve_extra: tuple[tuple[str, str], ...] = ()
    joins: Optional[tuple[str, str]] = None
    joins_differ: tuple[str, ...] = ()

    @property
    def argv(self) -> list[str]:
        """The sweep's arguments (after ``box2d-driving sweep``)."""
        return shlex.split(self.command)[2:]

    @cached_property  # parsed once per rule (~4 ms a parse): out, seeds and summary_name are read many times a page
    def args(self) -> Any:
        """The sweep's command line parsed by ``box2d-driving sweep``'s own parser (its defaults
        filled in), the one reading of ``command`` that every other property uses."""
        from training.sweeps.sweep import build_parser

        return build_parser().parse_args(self.argv)

    def spec(self) -> tuple[Any, Optional[int]]:
        """The sweep the command runs and its torch threads per trial (``spec_from_args``);
        ``SweepError`` where the command's grid or options are bad."""
        from training.sweeps.sweep import spec_from_args

        return spec_from_args(self.args)

    @property
    def out(self) -> Path:
        """The sweep folder the command names."""
        return Path(self.args.out)

    @property
    def seeds(self) -> int:
        """Training seeds per grid point the command asks for (the sweep's default where it names none)."""
        return self.args.seeds

    @property
    def summary_name(self) -> str:
        """File stem of the committed summary: the sweep folder's name without ``sweep-``."""
        return self.out.name.removeprefix("sweep-")
