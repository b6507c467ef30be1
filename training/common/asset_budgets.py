"""How much the repository's ``assets/`` folder may hold: every clone, checkout and copy to a
remote machine pays for it. ``tests/test_shipped_policies.py`` holds the repository to these
numbers and the results page states them."""

from __future__ import annotations

from dataclasses import dataclass

__all__ = ["ASSET_BUDGETS", "AssetBudgets"]

MIB = 2**20


@dataclass(frozen=True)
class AssetBudgets:
    """Sizes in bytes."""

    # the shipped policies (one small policy per result row), reports, maps, sweep summaries,
    # curves and trials carried part-way
    shipped: int = 25 * MIB
    # apart, each landed sweep trial's final actor (assets/sweeps/weights, ~0.3 MB a trial), kept so
    # that `reproduce --reevaluate` measures a trial again without retraining it (and `lidar-use`
    # whether it sees): the paper preset's lights sections are 34 trials with the paper code's
    # encoder in its mirror-image world (4-car grid, noise 1.0, lone car, 8 cars) and 34 in its
    # world on the left (the same four), beside the 22 of its first runs
    kept_weights: int = 32 * MIB
    # the paper's own trainer's runs (assets/original): a finished one keeps its last actor and
    # report (~0.4 MB), one still training its weights with both Adam states to resume from
    # (~2 MB) and the actors it kept that its curve.csv has not drawn yet (0.3 MB each)
    original_runs: int = 10 * MIB
    # no single file larger
    file: int = 2 * MIB

    @staticmethod
    def mib(size: int) -> str:
        """``size`` bytes in MiB, for prose: ``"25 MiB"``."""
        return f"{size / MIB:g} MiB"


ASSET_BUDGETS = AssetBudgets()
