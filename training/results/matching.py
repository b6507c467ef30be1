"""Which sweep summaries, and which of their grid points, measure a rule of the results page: a
summary belongs to the rule whose behaviour and fixed options it has (the most specific one, where
two match), a rule may join another's trials as extra grid points, and name another rule's grid
point to compare with."""

from __future__ import annotations

import math
from typing import Any, Optional

from training.results.data import Group, Metric, as_number, groups_of
from training.results.sections import IN_GRID, SECTIONS, Section, section as section_by_key

__all__ = ["group_at", "grid_order", "grid_value", "joined_groups", "reference", "section_summaries"]


def _setting(settings: dict[str, Any], key: str) -> str:
    """``key``'s value in a sweep's ``settings`` as a section's match spells it (``"false"`` where
    the sweep did not set it; a preset's encoder is filled in by ``load_summary``)."""
    return str(settings.get(key, "false")).lower()


def _matches(section: Section, summary: dict[str, Any]) -> bool:
    """Whether ``summary`` has ``section``'s behaviour and fixed options. A sweep in a preset's
    world measures only the sections that name that preset: its world and update are not ours."""
    sweep = summary["sweep"]
    # the trial budget counts too: the same settings at a larger budget may be a rule of its own
    settings = {"timesteps": sweep.get("timesteps"), **sweep.get("fixed", {}), **{k: IN_GRID for k in summary["grid"]}}
    if _setting(settings, "preset") != "false" and "preset" not in dict(section.match):
        return False
    return sweep["behaviour"] == section.behaviour and all(_setting(settings, k) == v for k, v in section.match)


def section_summaries(section: Section, summaries: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """The summaries that measure ``section``: its behaviour, its fixed options. A summary that
    two sections match goes to the more specific one (more fixed options), so the paper-settings
    lights sweep (4 cars fixed) is not also shown under the lights grid."""
    return [s for s in summaries if _matches(section, s)
            and not any(len(other.match) > len(section.match) and _matches(other, s) for other in SECTIONS)]


def joined_groups(section: Section, summaries: list[dict[str, Any]], summary: dict[str, Any],
                  metrics: list[Metric]) -> tuple[list[Group], list[str]]:
    """The grid points ``section.joins`` adds to ``summary`` (one of ``section``'s): the joined
    section's trials, their fixed value of the joined option added to their point. Only summaries
    of the same settings join: the same budget and fixed options but the joined one, and a grid of
    the same keys less that option (options in ``section.joins_differ`` may differ). Also returns
    those summaries' paths."""
    if section.joins is None:
        return [], []
    key, option = section.joins
    other = section_by_key(key)
    mine = summary["sweep"]
    groups, paths = [], []
    for theirs in section_summaries(other, summaries):
        sweep = theirs["sweep"]
        fixed = {k: v for k, v in sweep.get("fixed", {}).items() if k not in section.joins_differ}
        value = fixed.pop(option, None)
        ours = {k: v for k, v in mine.get("fixed", {}).items() if k not in section.joins_differ}
        if value is None or sorted([*theirs["grid"], option]) != sorted(summary["grid"]) or \
                fixed != ours or sweep.get("timesteps") != mine.get("timesteps"):
            continue
        paths.append(theirs["path"])
        groups += [Group({**g.point, option: str(value)}, g.seeds, g.estimates, g.figures)
                   for g in groups_of(theirs, metrics)]
    return groups, paths


def grid_value(v: str) -> tuple[int, float, str]:
    """A grid value's sort key: numbers by value, then the rest by name."""
    number = as_number(v)
    return (0, number, "") if math.isfinite(number) else (1, 0.0, v)


def grid_order(groups: list[Group], keys: list[str]) -> list[Group]:
    """``groups`` sorted by their grid values, key by key, numbers by value."""
    return sorted(groups, key=lambda g: tuple(grid_value(str(g.point[k])) for k in keys))


def group_at(section: Section, summaries: list[dict[str, Any]], metrics: list[Metric],
             point: tuple[tuple[str, str], ...]) -> Optional[Group]:
    """``section``'s trials at the grid ``point`` (the summary with most seeds there), with
    ``metrics`` estimated; None if not measured."""
    found = [g for s in section_summaries(section, summaries) for g in groups_of(s, metrics)
             if all(str(g.point.get(k)) == v for k, v in point)]
    return max(found, key=lambda g: len(g.seeds)) if found else None


def reference(section: Section, summaries: list[dict[str, Any]]) -> tuple[Optional[Group], str]:
    """The grid point ``section.compare_with`` names, from the summaries (None if not measured or
    none named), and its name in words."""
    if section.compare_with is None:
        return None, ""
    key, point = section.compare_with
    other = section_by_key(key)
    label = f"the row {', '.join(f'{k}={v}' for k, v in point)} of {other.title}"
    return group_at(other, summaries, [m for m, _ in other.metrics], point), label
