"""Traffic lights: two antiphase groups and the rule for which light a car can see.

Observation values: green 0.0, yellow 0.5, red 1.0, and 0.75 when no light is visible. Each light
cycles green ``T - y``, yellow ``y``, red ``T - y``, yellow ``y`` (seconds), where ``T`` is the
half period and ``y`` the yellow time; group 1 runs half a cycle behind group 0, so when one group
is green the other is red, and both show yellow together for ``y`` seconds between.
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass

import numpy as np
from numba import njit

GREEN = 0.0
YELLOW = 0.5
RED = 1.0
NO_LIGHT = 0.75


@dataclass(frozen=True)
class TrafficLights:
    """The lights of one junction for one episode.

    Attributes:
        stop_points: ``(L, 2)`` centre of each light's stop line (m).
        directions: ``(L, 2)`` unit travel direction of the approach the light controls.
        groups: ``(L,)`` group index, 0 or 1.
        half_period: ``T`` (s).
        yellow: yellow duration ``y`` (s).
        offset: phase at time 0 (s), in ``[0, 2T)``.
    """

    stop_points: np.ndarray
    directions: np.ndarray
    groups: np.ndarray
    half_period: float
    yellow: float
    offset: float

    def __len__(self) -> int:
        return len(self.groups)

    @functools.cached_property
    def _plain(self) -> tuple[list, list]:
        """Stop points and directions as plain float lists (read every decision by :meth:`seen`;
        the lights of an episode never change, so they are converted once)."""
        return self.stop_points.tolist(), self.directions.tolist()

    def values(self, time: float) -> np.ndarray:
        """Light value of every light at ``time`` seconds after reset, shape ``(L,)``."""
        cycle = 2.0 * self.half_period
        phase = (time + self.offset + self.groups * self.half_period) % cycle
        return phase_value(phase, self.half_period, self.yellow)

    def plain_values(self, time: float) -> list[float]:
        """:meth:`values` as a list, worked out in plain floats: the same operations in the same
        order (Python's float ``%`` and numpy's remainder are the same rule), so the same values,
        without a dozen numpy calls on an array of four lights."""
        t, y = self.half_period, self.yellow
        cycle = 2.0 * t
        base = time + self.offset
        out = []
        for g in self._groups:
            phase = (base + g * t) % cycle
            out.append(GREEN if phase < t - y else YELLOW if phase < t else RED if phase < 2 * t - y else YELLOW)
        return out

    @functools.cached_property
    def _groups(self) -> list[int]:
        return self.groups.tolist()

    def seen(self, time: float, light_index: np.ndarray, positions: np.ndarray,
             headings: np.ndarray, view_distance: float) -> np.ndarray:
        """The light value each car sees, shape ``(N,)``.

        A car sees only the light of its own approach (``light_index``, -1 for none), and only
        while its centre is within ``view_distance`` before the stop line and it faces the
        direction of travel (heading within 90 degrees); otherwise it sees ``NO_LIGHT``.
        """
        out = np.full(len(light_index), NO_LIGHT)
        if len(self) == 0:
            return out
        # A handful of cars each decision: plain floats, one pass, instead of a dozen numpy calls
        # on arrays of four (the same products and sums, so the same values to the bit).
        stops, dirs = self._plain
        cos_h, sin_h = np.cos(headings).tolist(), np.sin(headings).tolist()
        values = None
        for k, (li, (px, py)) in enumerate(zip(light_index.tolist(), positions.tolist())):
            if li < 0:
                continue
            (sx, sy), (dx, dy) = stops[li], dirs[li]
            ahead = (sx - px) * dx + (sy - py) * dy
            if 0.0 < ahead <= view_distance and cos_h[k] * dx + sin_h[k] * dy > 0.0:
                if values is None:  # most decisions no car is before a stop line
                    values = self.plain_values(time)
                out[k] = values[li]
        return out


def seen_by_cars(time: np.ndarray, stop_points: np.ndarray, directions: np.ndarray, groups: np.ndarray,
                 half_period: np.ndarray, yellow: np.ndarray, offset: np.ndarray, positions: np.ndarray,
                 headings: np.ndarray, view_distance: float) -> np.ndarray:
    """:meth:`TrafficLights.seen` for cars of several junctions at once, everything per car
    ``(n,)`` or ``(n, 2)``: the time of its junction (s), the stop point and direction of its own
    light (NaN for a car without one), that light's group, and its junction's half period, yellow
    time and phase offset. The same products and sums as :meth:`TrafficLights.seen`, so the same
    values to the bit (the env core calls its two halves, :func:`visible_lights` and
    :func:`light_values`, and works out the second's inputs only for the cars that see a light)."""
    out = np.full(len(time), NO_LIGHT)
    visible = visible_lights(stop_points, directions, positions, headings, view_distance)
    if visible.any():
        out[visible] = light_values(time[visible], groups[visible], half_period[visible], yellow[visible],
                                    offset[visible])
    return out


def visible_lights(stop_points: np.ndarray, directions: np.ndarray, positions: np.ndarray,
                   headings: np.ndarray, view_distance: float) -> np.ndarray:
    """Which cars see their light (see :func:`seen_by_cars`): centre within ``view_distance``
    before the stop line, facing the direction of travel."""
    return _visible(stop_points, directions, positions, np.cos(headings), np.sin(headings), float(view_distance))


@njit(cache=True)
def _visible(stop_points, directions, positions, cos_h, sin_h, view_distance):
    out = np.zeros(positions.shape[0], dtype=np.bool_)
    for i in range(positions.shape[0]):
        dx, dy = directions[i, 0], directions[i, 1]
        ahead = (stop_points[i, 0] - positions[i, 0]) * dx + (stop_points[i, 1] - positions[i, 1]) * dy
        # NaN (no light) fails every comparison
        out[i] = 0.0 < ahead <= view_distance and cos_h[i] * dx + sin_h[i] * dy > 0.0
    return out


def visible_from_points(stop_points: np.ndarray, view_points: np.ndarray, directions: np.ndarray,
                        positions: np.ndarray, view_distance: float) -> np.ndarray:
    """Which cars see their light by the paper's code's rule (``light_view="axis_point"``): its
    centre within ``view_distance`` (m, straight line, strictly) of its light's ``view_points``
    (where its arm's axis meets the junction) and not yet past the line through ``stop_points``
    across ``directions``. NaN rows (no light) see none."""
    return _visible_from_points(stop_points, view_points, directions, positions, float(view_distance))


@njit(cache=True)
def _visible_from_points(stop_points, view_points, directions, positions, view_distance):
    out = np.zeros(positions.shape[0], dtype=np.bool_)
    for i in range(positions.shape[0]):
        ahead = ((stop_points[i, 0] - positions[i, 0]) * directions[i, 0]
                 + (stop_points[i, 1] - positions[i, 1]) * directions[i, 1])
        dx, dy = view_points[i, 0] - positions[i, 0], view_points[i, 1] - positions[i, 1]
        out[i] = 0.0 < ahead and math.sqrt(dx * dx + dy * dy) < view_distance
    return out


def light_values(time: np.ndarray, groups: np.ndarray, half_period: np.ndarray, yellow: np.ndarray,
                 offset: np.ndarray) -> np.ndarray:
    """The value of each car's light (per car, as :func:`seen_by_cars` takes them), as
    :meth:`TrafficLights.values` computes it for its junction."""
    phase = (time + offset + groups * half_period) % (2.0 * half_period)
    return phase_value(phase, half_period, yellow)


def phase_value(phase: np.ndarray, half_period: float | np.ndarray, yellow: float | np.ndarray) -> np.ndarray:
    """Value of a group-0 light at ``phase`` seconds into its ``2T`` cycle."""
    phase = np.asarray(phase, dtype=np.float64)
    t = half_period
    # nested where, not np.select: the same values, a few times cheaper on the handful of lights
    # a junction has (this runs every decision)
    return np.where(phase < t - yellow, GREEN,
                    np.where(phase < t, YELLOW, np.where(phase < 2 * t - yellow, RED, YELLOW)))


def sample_lights(rng: np.random.Generator, stop_points: np.ndarray, directions: np.ndarray,
                  groups: np.ndarray, period_range: tuple[float, float], yellow: float,
                  start: str = "random_phase", period_step: float = 0.0,
                  first_green: float = 0.5) -> TrafficLights:
    """Lights with ``T ~ U[period_range)`` (rounded down to a multiple of ``period_step`` s when
    it is positive) and a start phase that is uniformly random (``start="random_phase"``) or the
    beginning of green for group 0 with probability ``first_green``, else of red
    (``"green_or_red"``)."""
    half_period = float(rng.uniform(*period_range))
    if period_step > 0.0:
        half_period = math.floor(half_period / period_step) * period_step
    if start == "green_or_red" and first_green == 0.5:  # the draw every world before first_green made
        offset = float(half_period * rng.integers(2))
    elif start == "green_or_red":
        offset = half_period * float(rng.random() >= first_green)
    else:
        offset = float(rng.uniform(0.0, 2.0 * half_period))
    return TrafficLights(np.asarray(stop_points, float), np.asarray(directions, float),
                         np.asarray(groups, np.int64), half_period, yellow, offset)
