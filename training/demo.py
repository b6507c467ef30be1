"""The main job: a short real training run, its report, and the shipped policy on video.

    python training/demo.py --out runs/demo

1. trains the traffic-light scenario for a short run (``traffic_lights.py --quick``);
2. evaluates that checkpoint (``OUT/quick/eval``: metrics.json, learning curves, plots);
3. evaluates the shipped policy ``traffic_lights_4cars_noise05`` (``assets/policies/``) and
   records a video of it
   (``OUT/shipped/``), so the rule a longer run learns is visible at once.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path
from typing import Optional

from box2d_driving.policies.shipped import shipped_policy
from training.evaluation import evaluate
from training.behaviours import traffic_lights
from training.behaviours.scripts import QUICK
from training.common.cli_args import error, parse

SHIPPED = shipped_policy("traffic_lights_4cars_noise05")  # assets/policies, or the wheel's copy


@dataclass
class Args:
    """Run the main job.

    out: output folder (must not exist)
    episodes: evaluation episodes for each report
    threads: torch CPU threads of the training run (default: the cores left free; 1 on a machine other jobs keep busy)
    """

    out: str = "runs/demo"
    episodes: int = 50
    threads: Optional[int] = None


def main(argv: Optional[list[str]] = None) -> int:
    args = parse(Args, argv, description=__doc__.split("\n\n")[0])
    out = Path(args.out)
    if out.exists() and any(out.iterdir()):
        return error(f"{out} exists and is not empty; choose another --out")
    print("== 1/3 short training run (traffic lights, 4 cars)")
    threads = [] if args.threads is None else ["--threads", str(args.threads)]
    if traffic_lights.main(["--quick", "--out", str(out / "quick"), *threads]) != 0:
        return 1
    print("== 2/3 evaluating the short run")
    n = str(args.episodes)
    if evaluate.main(["--checkpoint", str(out / "quick"), "--episodes", n,
                      "--out", str(out / "quick" / "eval")]) != 0:
        return 1
    print("== 3/3 evaluating the shipped policy and recording a video")
    if evaluate.main(["--checkpoint", str(SHIPPED), "--episodes", n, "--video", "2",
                      "--out", str(out / "shipped")]) != 0:
        return 1
    quick = json.loads((out / "quick" / "eval" / "metrics.json").read_text())
    shipped = json.loads((out / "shipped" / "metrics.json").read_text())
    print("\n| policy | success | collision | red-light violation |\n|---|---:|---:|---:|")
    rows = ((f"short run ({QUICK.timesteps:,} decisions)", quick), ("shipped (10 min, LiDAR noise 0.5)", shipped))
    for name, m in rows:
        print(f"| {name} | {m['success_rate']:.3f} | {m['collision_rate']:.3f} | "
              f"{m['red_light_violation_rate']:.3f} |")
    print(f"\nreports and plots: {out / 'quick' / 'eval'}, {out / 'shipped'}; "
          f"video: {out / 'shipped' / 'episodes.mp4'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
