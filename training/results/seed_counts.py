"""How many training seeds: the paired differences between two grid points, and how many seeds
the measured spread would need before a 95 % interval tells (a planning estimate the results
page prints beside an interval that does not yet exclude zero)."""

from __future__ import annotations

import math
from typing import Sequence

from box2d_driving.metrics.stats import half_width, mean_var, t95
from training.results.data import Group, Metric

__all__ = ["paired_differences", "seeds_needed", "seeds_needed_apart"]


def paired_differences(a: Group, b: Group, metric: Metric) -> list[float]:
    """``b``'s value minus ``a``'s for every training seed both grid points have (empty where a
    seed's value is missing at either, so seeds cannot be matched)."""
    ea, eb = a.estimates[metric], b.estimates[metric]
    if len(ea.values) != len(a.seeds) or len(eb.values) != len(b.seeds):
        return []
    va, vb = dict(zip(a.seeds, ea.values)), dict(zip(b.seeds, eb.values))
    return [vb[s] - va[s] for s in sorted(set(va) & set(vb))]


def seeds_needed(diffs: Sequence[float], most: int = 200) -> str:
    """How many seeds the observed differences (paired, or each seed's value minus a reference
    number; their mean and spread taken as true) would need for a 95 % interval that excludes
    zero, in words ("" when they cannot tell)."""
    mean, var = mean_var(diffs)
    sd = math.sqrt(var)
    if mean == 0.0 or sd == 0.0:
        return ""
    for k in range(2, most + 1):
        if half_width(sd, k) < abs(mean):
            return f"; a planning estimate, taking this mean and spread as true: about {k} seeds would tell"
    return f"; a planning estimate, taking this mean and spread as true: more than {most} seeds would be needed"


def seeds_needed_apart(a: Sequence[float], b: Sequence[float], most: int = 200) -> str:
    """How many seeds per row two independent rows (their means and spreads taken as true) would
    need for a 95 % interval of their difference (Welch) that excludes zero, in words ("" when
    they cannot tell)."""
    if len(a) < 2 or len(b) < 2:
        return ""
    (ma, va), (mb, vb) = mean_var(a), mean_var(b)
    if ma == mb or va + vb == 0.0:
        return ""
    for k in range(2, most + 1):
        # Welch-Satterthwaite degrees of freedom with k seeds in each row
        dof = (va + vb) ** 2 * (k - 1) / (va * va + vb * vb) if va * vb else k - 1
        if t95(max(1, int(dof))) * math.sqrt((va + vb) / k) < abs(ma - mb):
            return (f"; a planning estimate, taking this difference and spread as true: about {k} seeds per row "
                    f"would tell")
    return (f"; a planning estimate, taking this difference and spread as true: more than {most} seeds per row "
            f"would be needed")
