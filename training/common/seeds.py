"""The three disjoint ranges of episode seeds, named in one place.

* **training**: everything a training run hands to ``reset(seed=)``: its run seed plus instance,
  round and resume offsets (all below :data:`TRAINING`'s end, checked when the envs are seeded);
* **selection**: episodes that choose something (a checkpoint, an entropy, a budget);
* **report**: episodes behind every published number (``evaluate``, sweep trials, the results
  page). Nothing is reported on selection or training seeds: the evaluation entry points refuse
  them.

An episode seed fixes the whole episode (map, spawns, lights, pedestrians, LiDAR noise), so a
disjoint range means the reported episodes were never seen in training or selection.
"""

from __future__ import annotations

from dataclasses import dataclass


class SeedError(ValueError):
    """Episode seeds outside the range their use requires."""


@dataclass(frozen=True)
class SeedRange:
    """Episode seeds ``start <= seed < stop`` for one use."""

    name: str
    start: int
    stop: int

    def __contains__(self, seed: object) -> bool:
        return isinstance(seed, int) and not isinstance(seed, bool) and self.start <= seed < self.stop

    def episodes(self, count: int, first: int | None = None) -> range:
        """Seeds of ``count`` episodes from ``first`` (default: the range's start); :class:`SeedError`
        unless all of them lie in the range."""
        first = self.start if first is None else first
        if count < 1:
            raise SeedError(f"{self.name} episodes: count must be >= 1, got {count}")
        if first not in self or first + count - 1 not in self:
            raise SeedError(f"episode seeds {first}..{first + count - 1} are not all {self.name} seeds "
                            f"({self.describe()})")
        return range(first, first + count)

    def describe(self) -> str:
        return f"{self.name} seeds are {self.start:,}..{self.stop - 1:,}"


TRAINING = SeedRange("training", 0, 1_000_000_000)
SELECTION = SeedRange("selection", 1_000_000_000, 1_500_000_000)
REPORT = SeedRange("report", 1_500_000_000, 2_000_000_000)

#: The largest ``--seed`` of a training run; its env seeds add instance, round and resume offsets.
MAX_RUN_SEED = 1_000_000


def which(seed: int) -> str:
    """The name of the range ``seed`` lies in ("training", "selection", "report" or "none")."""
    for r in (TRAINING, SELECTION, REPORT):
        if seed in r:
            return r.name
    return "none"


def check_training_seeds(first: int, count: int) -> None:
    """Refuse to hand a training run's envs seeds outside :data:`TRAINING`."""
    if first is not None:
        TRAINING.episodes(count, first)
