"""Pedestrians: cars learn to slow down at the crosswalk on ``crosswalk-v0``.

    box2d-driving train crosswalk --timesteps 3000000 --out runs/crosswalk
    box2d-driving train crosswalk --quick --out runs/crosswalk_quick

Then ``box2d-driving evaluate --checkpoint runs/crosswalk --episodes 200 --out runs/crosswalk/eval``
(which also evaluates the policy with pedestrians invisible to the LiDAR, as a control).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

from box2d_driving.envs.crosswalk import CrosswalkConfig
from training.behaviours.algorithms import run_script
from training.behaviours.scripts import ScriptArgs

ENV_ID = "crosswalk-v0"


@dataclass
class Args(ScriptArgs):
    """Train cars to slow down for pedestrians on crosswalk-v0.

    crosswalk_in_satnav: the sat-nav also tells how far ahead the crosswalk is (not in the paper)
    """

    num_cars: int = CrosswalkConfig.num_cars  # the scenario's, declared once in its config
    out: str = "runs/crosswalk"
    crosswalk_in_satnav: bool = False

    def env_overrides(self) -> dict:
        return {"crosswalk_in_satnav": self.crosswalk_in_satnav}


def main(argv: Optional[list[str]] = None) -> int:
    return run_script(ENV_ID, Args, argv, __doc__)


if __name__ == "__main__":
    raise SystemExit(main())
