"""Markdown table of evaluation reports: ``python training/experiments/table.py A/metrics.json ...``."""

from __future__ import annotations

import json
import sys
from pathlib import Path

COLUMNS = ("success_rate", "collision_rate", "red_light_violation_rate", "stop_value",
           "mean_time_to_goal")


def main(paths: list[str]) -> int:
    print("| run | cars | noise | agent-steps | minutes | success | collision | violation | stop value | time to goal |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for p in paths:
        m = json.loads(Path(p).read_text())
        name = Path(p).parent.parent.name
        env = m.get("env_config", {})
        tr = m.get("training", {})
        vals = [m.get(c, float("nan")) for c in COLUMNS]
        print(f"| {name} | {env.get('num_cars')} | {env.get('lidar_noise')} | "
              f"{tr.get('agent_steps', 0):,} | {tr.get('wall_s', 0) / 60:.1f} | "
              + " | ".join(f"{v:.3f}" if isinstance(v, float) else str(v) for v in vals) + " |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
