"""Lanes emerge at the junction: bilevel training on ``intersection-spline-v0``.

Each car first picks its path (216 offsets of its route's three waypoints), then drives it; lanes
are never given. The paper: with 8 cars and noisy LiDAR, cars settle on one side.

    box2d-driving train lanes --num-cars 8 --lidar-noise 0.5 --rounds 40 --out runs/lanes8 \\
        --init-from assets/policies/traffic_lights_4cars_noise05
    box2d-driving train lanes --quick --out runs/lanes_quick          # a real, short run
    box2d-driving train lanes --resume --out runs/lanes8 --rounds 60

Then ``box2d-driving evaluate --checkpoint runs/lanes8 --episodes 200 --out runs/lanes8/eval``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

from box2d_driving.envs.intersection_spline import IntersectionSplineConfig
from training.behaviours.algorithms import run_script
from training.behaviours.scripts import BilevelArgs

ENV_ID = "intersection-spline-v0"


@dataclass
class Args(BilevelArgs):
    """Train cars to choose their paths and drive them on intersection-spline-v0.

    spline_action: how the path policy picks its 216 paths: per_waypoint (one 6-way choice per waypoint, the
        default) or joint (one 216-way choice, as the paper's code)
    """

    num_cars: int = IntersectionSplineConfig.num_cars  # the scenario's, declared once in its config
    lidar_noise: float = IntersectionSplineConfig.lidar_noise
    out: str = "runs/lanes"
    spline_action: str = IntersectionSplineConfig.spline_action

    def env_overrides(self) -> dict:
        # runs with the scenario's default keep their recorded overrides
        default = IntersectionSplineConfig.spline_action
        return {} if self.spline_action == default else {"spline_action": self.spline_action}


def main(argv: Optional[list[str]] = None) -> int:
    return run_script(ENV_ID, Args, argv, __doc__)


if __name__ == "__main__":
    raise SystemExit(main())
