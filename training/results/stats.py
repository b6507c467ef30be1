"""Across training seeds: the mean of a metric and its 95 % confidence interval (Student's t).

With 3 seeds the interval is wide (t = 4.30 for 2 degrees of freedom): that is the honest width
of what three runs can say, and the reason every result page shows the per-seed values beside it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable, Optional

# two-sided 95 % quantiles of Student's t, by degrees of freedom (standard table values)
_T95 = {1: 12.706, 2: 4.303, 3: 3.182, 4: 2.776, 5: 2.571, 6: 2.447, 7: 2.365, 8: 2.306, 9: 2.262,
        10: 2.228, 11: 2.201, 12: 2.179, 13: 2.160, 14: 2.145, 15: 2.131, 16: 2.120, 17: 2.110,
        18: 2.101, 19: 2.093, 20: 2.086, 25: 2.060, 30: 2.042, 40: 2.021, 60: 2.000, 120: 1.980}


def t95(dof: int) -> float:
    """The two-sided 95 % t quantile for ``dof`` degrees of freedom (the next tabulated smaller
    dof where the table has a gap, which errs on the wide side; 1.96 beyond 120)."""
    if dof < 1:
        raise ValueError(f"degrees of freedom must be >= 1, got {dof}")
    if dof > 120:
        return 1.960
    return _T95[max(k for k in _T95 if k <= dof)]


@dataclass(frozen=True)
class Estimate:
    """Mean over seeds with a 95 % interval; ``low``/``high`` are None for fewer than 2 values."""

    mean: float
    low: Optional[float]
    high: Optional[float]
    n: int
    values: tuple[float, ...]

    def contains(self, x: float) -> Optional[bool]:
        """Whether ``x`` lies in the interval (None without an interval)."""
        if self.low is None or self.high is None:
            return None
        return self.low <= x <= self.high

    def format(self, digits: int = 3) -> str:
        if self.low is None:
            return f"{self.mean:.{digits}f} (1 seed)"
        half = (self.high - self.low) / 2
        return f"{self.mean:.{digits}f} ± {half:.{digits}f}"


def mean_ci(values: Iterable[float]) -> Estimate:
    """Mean and 95 % t-interval of the finite ``values`` (NaNs, e.g. a metric a run could not
    measure, are left out and not counted)."""
    xs = tuple(float(v) for v in values if v is not None and math.isfinite(float(v)))
    if not xs:
        return Estimate(math.nan, None, None, 0, ())
    mean = sum(xs) / len(xs)
    if len(xs) < 2:
        return Estimate(mean, None, None, 1, xs)
    sd = math.sqrt(sum((x - mean) ** 2 for x in xs) / (len(xs) - 1))
    half = t95(len(xs) - 1) * sd / math.sqrt(len(xs))
    return Estimate(mean, mean - half, mean + half, len(xs), xs)
