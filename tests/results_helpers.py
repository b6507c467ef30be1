"""Hand-built sweep summaries and a table check shared by the results-page tests."""

from __future__ import annotations

import json
import re

from training.common.seeds import REPORT


def ragged_tables(text: str) -> list[str]:
    """Markdown table rows whose number of cells differs from their table's header (an unescaped
    ``|`` inside a cell splits it)."""
    bad, width = [], None
    for line in text.splitlines():
        if not line.startswith("|"):
            width = None
            continue
        cells = len(re.split(r"(?<!\\)\|", line)) - 2
        width = cells if width is None else width
        if cells != width:
            bad.append(line)
    return bad


def lights_summary(path, violations, first_seed=REPORT.start, statuses=None):
    """A lights sweep over noise {0, 0.5} x cars {1, 4}, 3 seeds, with given violation rates."""
    trials = []
    for (noise, cars), values in violations.items():
        for seed, v in enumerate(values):
            name = f"lights_lidar_noise={noise}_num_cars={cars}_seed={seed}"
            trials.append({"trial": name, "behaviour": "lights", "seed": seed, "lidar_noise": noise,
                           "num_cars": cars, "status": (statuses or {}).get(name, "done"), "error": "",
                           "report_episodes": 200, "report_first_seed": first_seed,
                           "red_light_violation_rate": v, "success_rate": 0.9, "collision_rate": 0.05})
    sweep = {"behaviour": "lights", "grid": {"lidar_noise": ["0", "0.5"], "num_cars": ["1", "4"]},
             "seeds": 3, "fixed": {}, "timesteps": 991552, "minutes": None, "episodes": 200, "quick": False}
    path.write_text(json.dumps({"sweep": sweep, "trials": trials}))
    return path


VIOLATIONS = {("0", "1"): [0.40, 0.47, 0.50], ("0", "4"): [0.10, 0.12, 0.08],
              ("0.5", "1"): [0.30, 0.35, 0.40], ("0.5", "4"): [0.05, 0.07, 0.06]}
