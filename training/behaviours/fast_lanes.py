"""Fast lanes emerge on the highway: bilevel training on ``highway-spline-v0``.

Each car sees its acceleration rating, picks a lateral target, then drives; the paper: faster
cars settle on one side.

    box2d-driving train fast-lanes --num-cars 10 --rounds 40 --out runs/fast_lanes
    box2d-driving train fast-lanes --quick --out runs/fast_lanes_quick  # a real, short run
    box2d-driving train fast-lanes --resume --out runs/fast_lanes --rounds 60

Then ``box2d-driving evaluate --checkpoint runs/fast_lanes --episodes 100 --out runs/fast_lanes/eval``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

from box2d_driving.envs.highway_spline import HighwaySplineConfig
from training.behaviours.algorithms import run_script
from training.behaviours.scripts import BilevelArgs

ENV_ID = "highway-spline-v0"


@dataclass
class Args(BilevelArgs):
    """Train cars to choose their lateral position and drive on highway-spline-v0."""

    num_cars: int = HighwaySplineConfig.num_cars  # the scenario's, declared once in its config
    out: str = "runs/fast_lanes"


def main(argv: Optional[list[str]] = None) -> int:
    return run_script(ENV_ID, Args, argv, __doc__)


if __name__ == "__main__":
    raise SystemExit(main())
