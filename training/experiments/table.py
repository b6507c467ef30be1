"""Markdown table of evaluation reports: ``python training/experiments/table.py A/metrics.json ...``
(or the folders holding them). Columns follow the first report's scenario."""

from __future__ import annotations

import json
import sys
from pathlib import Path

LIGHT_COLUMNS = {"success": "success_rate", "collision": "collision_rate",
                 "violation": "red_light_violation_rate", "stop value": "stop_value",
                 "time to goal": "mean_time_to_goal"}
CROSSWALK_COLUMNS = {"success": "success_rate", "collision": "collision_rate",
                     "pedestrian collision": "pedestrian_collision_rate",
                     "safe-stopping share": "safe_stopping_share", "> 6 m": "share_more_than_6m",
                     "time to goal": "mean_time_to_goal",
                     "invisible: pedestrian collision": "invisible_pedestrians.pedestrian_collision_rate"}


def _get(metrics: dict, key: str):
    for part in key.split("."):
        if not isinstance(metrics, dict) or part not in metrics:
            return float("nan")
        metrics = metrics[part]
    return metrics


def main(paths: list[str]) -> int:
    reports = [Path(p) / "metrics.json" if Path(p).is_dir() else Path(p) for p in paths]
    loaded = [json.loads(p.read_text()) for p in reports]
    crosswalk = bool(loaded) and str(loaded[0].get("env_id", "")).startswith("crosswalk")
    columns = CROSSWALK_COLUMNS if crosswalk else LIGHT_COLUMNS
    print("| run | cars | noise | agent-steps | minutes | " + " | ".join(columns) + " |")
    print("|---|---:|---:|---:|---:|" + "---:|" * len(columns))
    for p, m in zip(reports, loaded):
        env = m.get("env_config", {})
        tr = m.get("training", {})
        vals = [_get(m, key) for key in columns.values()]
        print(f"| {p.parent.parent.name} | {env.get('num_cars')} | {env.get('lidar_noise')} | "
              f"{tr.get('agent_steps', 0):,} | {tr.get('wall_s', 0) / 60:.1f} | "
              + " | ".join(f"{v:.3f}" if isinstance(v, float) else str(v) for v in vals) + " |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
