"""Across training seeds: the mean of a metric and its 95 % confidence interval (Student's t).

With 3 seeds the interval is wide (t = 4.30 for 2 degrees of freedom): that is the honest width
of what three runs can say, and the reason every result page shows the per-seed values beside it.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from typing import Iterable, Optional, Sequence

# how an estimate from one training seed prints after its mean (no interval): the claims table
# finds single-seed statements by it
ONE_SEED = "(1 seed)"

def t95(dof: float) -> float:
    """The two-sided 95 % quantile of Student's t for ``dof`` degrees of freedom, exact to 1e-12
    (found by bisection on the distribution's tail, :func:`incomplete_beta`; 1.960 is only its
    limit): ``P(|T| > t95(dof)) = 0.05``."""
    if not dof >= 1:
        raise ValueError(f"degrees of freedom must be >= 1, got {dof}")
    return _t95(float(dof))


@functools.lru_cache(maxsize=None)
def _t95(dof: float) -> float:
    low, high = 1.9, 13.0  # the quantile lies between its normal limit and its value at dof = 1
    for _ in range(100):
        mid = 0.5 * (low + high)
        if incomplete_beta(dof / 2.0, 0.5, dof / (dof + mid * mid)) > 0.05:
            low = mid
        else:
            high = mid
        if high - low < 1e-12:
            break
    return 0.5 * (low + high)


def half_width(sd: float, n: int) -> float:
    """The 95 % t-interval's half-width for the mean of ``n`` values of standard deviation ``sd``."""
    return t95(n - 1) * sd / math.sqrt(n)


@dataclass(frozen=True)
class Estimate:
    """Mean over seeds with a 95 % interval; ``low``/``high`` are None for fewer than 2 values."""

    mean: float
    low: Optional[float]
    high: Optional[float]
    n: int
    values: tuple[float, ...]

    @property
    def interval(self) -> tuple[float, float]:
        """``(low, high)``; a :class:`ValueError` where there is none (fewer than 2 values)."""
        if self.low is None or self.high is None:
            raise ValueError(f"no interval from {self.n} value(s)")
        return self.low, self.high

    def contains(self, x: float) -> Optional[bool]:
        """Whether ``x`` lies in the interval (None without an interval)."""
        if self.low is None or self.high is None:
            return None
        return self.low <= x <= self.high

    clipped: bool = False  # the t-interval reached past the metric's range and was cut there

    def format(self, digits: int = 3) -> str:
        if self.low is None or self.high is None:
            return f"{fixed(self.mean, digits)} {ONE_SEED}"
        if self.clipped:  # asymmetric once cut: both ends
            return f"{fixed(self.mean, digits)} [{fixed(self.low, digits)}, {fixed(self.high, digits)}]"
        half = (self.high - self.low) / 2
        return f"{fixed(self.mean, digits)} ± {fixed(half, digits)}"


def fixed(x: float, digits: int = 3) -> str:
    """``x`` with ``digits`` decimals, and no minus sign on a value that rounds to zero (a change
    of -1e-17 reads "0.000", not "-0.000")."""
    text = f"{x:.{digits}f}"
    return text[1:] if text.startswith("-") and float(text) == 0.0 else text


def p_text(p: Optional[float]) -> str:
    """A p-value as a statement prints it: ``p = 0.014``, or ``p < 0.001`` for one that three
    decimals would show as zero (a test against a row of identical values can give 1e-30);
    None (a test of fewer than two values) reads ``no p-value (fewer than two seeds)``."""
    if p is None:
        return "no p-value (fewer than two seeds)"
    return "p < 0.001" if p < 0.0005 else f"p = {p:.3f}"


def finite(values: Iterable[Optional[float]]) -> tuple[float, ...]:
    """The finite ``values`` as floats (None and NaN, e.g. a metric a run could not measure, left out)."""
    return tuple(float(v) for v in values if v is not None and math.isfinite(float(v)))


def mean_var(xs: Sequence[float]) -> tuple[float, float]:
    """Mean and sample variance (divided by ``n - 1``) of two or more values."""
    mean = sum(xs) / len(xs)
    return mean, sum((x - mean) ** 2 for x in xs) / (len(xs) - 1)


def mean_ci(values: Iterable[float], bounds: Optional[tuple[float, float]] = None) -> Estimate:
    """Mean and 95 % t-interval of the finite ``values`` (NaNs, e.g. a metric a run could not
    measure, are left out and not counted). ``bounds``: the metric's range (a share's [0, 1]); an
    interval reaching past it is cut at it (``clipped``), since no seed can lie outside."""
    xs = finite(values)
    if not xs:
        return Estimate(math.nan, None, None, 0, ())
    if len(xs) < 2:
        return Estimate(sum(xs) / len(xs), None, None, 1, xs)
    mean, var = mean_var(xs)
    half = half_width(math.sqrt(var), len(xs))
    low, high = mean - half, mean + half
    if bounds is not None and (low < bounds[0] or high > bounds[1]):
        return Estimate(mean, max(low, bounds[0]), min(high, bounds[1]), len(xs), xs, clipped=True)
    return Estimate(mean, low, high, len(xs), xs)


def _beta_fraction(a: float, b: float, x: float, iterations: int = 300, eps: float = 1e-14) -> float:
    """The continued fraction of the regularised incomplete beta function (modified Lentz)."""
    tiny = 1e-300

    def guard(v: float) -> float:
        return v if abs(v) > tiny else tiny

    c, d = 1.0, 1.0 / guard(1.0 - (a + b) * x / (a + 1.0))
    h = d
    for m in range(1, iterations + 1):
        for aa in (m * (b - m) * x / ((a - 1.0 + 2 * m) * (a + 2 * m)),
                   -(a + m) * (a + b + m) * x / ((a + 2 * m) * (a + 1.0 + 2 * m))):
            d = 1.0 / guard(1.0 + aa * d)
            c = guard(1.0 + aa / c)
            h *= d * c
        if abs(d * c - 1.0) < eps:
            break
    return h


def incomplete_beta(a: float, b: float, x: float) -> float:
    """The regularised incomplete beta function ``I_x(a, b)``."""
    if x <= 0.0:
        return 0.0
    if x >= 1.0:
        return 1.0
    front = math.exp(math.lgamma(a + b) - math.lgamma(a) - math.lgamma(b) + a * math.log(x) + b * math.log1p(-x))
    if x < (a + 1.0) / (a + b + 2.0):
        return front * _beta_fraction(a, b, x) / a
    return 1.0 - front * _beta_fraction(b, a, 1.0 - x) / b


def t_test_p(values: Iterable[float], value: float) -> Optional[float]:
    """Two-sided p-value of the one-sample t-test that the mean of ``values`` is ``value`` (None
    for fewer than two values; 0 when they are all equal and differ from ``value``)."""
    xs = finite(values)
    if len(xs) < 2:
        return None
    n = len(xs)
    mean, var = mean_var(xs)
    sd = math.sqrt(var)
    if sd == 0.0:
        return 1.0 if mean == value else 0.0
    t = (mean - value) / (sd / math.sqrt(n))
    dof = n - 1
    return incomplete_beta(dof / 2.0, 0.5, dof / (dof + t * t))


def welch_p(a: Iterable[float], b: Iterable[float]) -> Optional[float]:
    """Two-sided p-value of Welch's t-test that two independent samples (say, the training seeds
    of two rows that were not trained in pairs) have the same mean; None with fewer than two
    values in either (0 or 1 when both spreads are zero)."""
    xs, ys = finite(a), finite(b)
    if len(xs) < 2 or len(ys) < 2:
        return None
    (mx, vx), (my, vy) = mean_var(xs), mean_var(ys)
    vx, vy = vx / len(xs), vy / len(ys)  # squared standard errors
    if vx + vy == 0.0:
        return 1.0 if mx == my else 0.0
    t = (mx - my) / math.sqrt(vx + vy)
    # Welch-Satterthwaite degrees of freedom (real-valued: the incomplete beta takes any)
    dof = (vx + vy) ** 2 / (vx * vx / (len(xs) - 1) + vy * vy / (len(ys) - 1))
    return incomplete_beta(dof / 2.0, 0.5, dof / (dof + t * t))
