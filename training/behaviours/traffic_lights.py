"""Traffic lights emerge at the junction: train cars on ``intersection-v0``.

    box2d-driving train lights --num-cars 4 --timesteps 3000000 --out runs/lights4
    box2d-driving train lights --quick --out runs/quick        # a real, short run
    box2d-driving train lights --resume --out runs/lights4 --timesteps 6000000

Then ``box2d-driving evaluate --checkpoint runs/lights4 --episodes 200 --out runs/lights4/eval``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

from box2d_driving.envs.intersection import IntersectionConfig
from training.behaviours.algorithms import run_script
from training.behaviours.scripts import ScriptArgs

ENV_ID = "intersection-v0"


@dataclass
class Args(ScriptArgs):
    """Train the traffic-light rule on intersection-v0.

    approach_order: which arm each car starts on: fixed (car i on arm i mod 4), rotate (round robin
        from a random first arm: the paper's 4-car runs) or random (each car's arm uniform at random:
        the paper's 8-car run); default: the scenario's, or the preset's
    drive_on: the side of the road the cars keep to: right, or left (the paper's code, its mirror
        image); default: the scenario's, or the preset's
    arrived_heading_error: an arrived car's heading error: zero, or minus_heading (the paper's code);
        default: the scenario's, or the preset's
    goal_distance: the sat-nav's distance to the goal: path (along the track), or straight (to the
        goal point, the paper's code); default: the scenario's, or the preset's
    light_view: where a car sees its light from: stop_line (within the view distance before its
        stop line), or axis_point (the paper's code: within that straight-line distance of its
        arm's axis at the junction); default: the scenario's, or the preset's
    integration: how a car's motion advances over a physics step: exact, or euler (the paper's
        code: at the step's starting speed); default: the scenario's, or the preset's
    """

    num_cars: int = IntersectionConfig.num_cars  # the scenario's, declared once in its config
    out: str = "runs/traffic_lights"
    approach_order: Optional[str] = None
    drive_on: Optional[str] = None
    arrived_heading_error: Optional[str] = None
    goal_distance: Optional[str] = None
    light_view: Optional[str] = None
    integration: Optional[str] = None

    def env_overrides(self) -> dict:
        given = {"approach_order": self.approach_order, "drive_on": self.drive_on,
                 "arrived_heading_error": self.arrived_heading_error, "goal_distance": self.goal_distance,
                 "light_view": self.light_view, "integration": self.integration}
        return {k: v for k, v in given.items() if v is not None}


def main(argv: Optional[list[str]] = None) -> int:
    return run_script(ENV_ID, Args, argv, __doc__)


if __name__ == "__main__":
    raise SystemExit(main())
