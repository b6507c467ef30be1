"""Right of way, turn signals and safe following distance on real junctions:
train cars on ``real-junction-v0`` (the shipped Helsinki junctions, one sampled per episode).

    box2d-driving train real-junction --num-cars 8 --timesteps 3000000 --out runs/real_junction
    box2d-driving train real-junction --communication --lidar-noise 0.5 --out runs/real_junction_comm
    box2d-driving train real-junction --quick --out runs/real_junction_quick       # a real, short run

Then ``box2d-driving evaluate --checkpoint runs/real_junction --episodes 200 --out
runs/real_junction/eval`` (FIFO share, safe-distance share and scatter, communication metrics) and
``box2d-driving curve runs/real_junction`` (FIFO over training).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Optional

from box2d_driving.envs.real_junction import RealJunctionConfig
from training.behaviours.algorithms import run_script
from training.behaviours.scripts import ScriptArgs

ENV_ID = "real-junction-v0"


@dataclass
class Args(ScriptArgs):
    """Train cars through real junctions on real-junction-v0.

    communication: each car also sends one bit per decision (the turn-signal option)
    comm_fallback: with communication, what a car hearing no other car receives: zero (the default) or own
        (its own last bit)
    map: one shipped map name or a map JSON file (default: all shipped maps, one per episode)
    """

    num_cars: int = RealJunctionConfig.num_cars  # the scenario's, declared once in its config
    out: str = "runs/real_junction"
    communication: bool = False
    comm_fallback: str = "zero"
    map: Optional[str] = None

    def env_overrides(self) -> dict:
        extra: dict[str, Any] = {"communication": self.communication}
        if self.comm_fallback != "zero":  # runs without it keep their recorded overrides
            extra["comm_fallback"] = self.comm_fallback
        if self.map is not None:
            extra["map"] = self.map
        return extra


def main(argv: Optional[list[str]] = None) -> int:
    return run_script(ENV_ID, Args, argv, __doc__)


if __name__ == "__main__":
    raise SystemExit(main())
