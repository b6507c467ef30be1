"""Every policy shipped under assets/policies loads, matches the settings its report says it was
evaluated with, and drives its scenario."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from box2d_driving.metrics.rollouts import run_episodes
from training.inference import load_policy

ROOT = Path(__file__).resolve().parent.parent
REPORTS = sorted((ROOT / "assets" / "policies").glob("**/eval/metrics.json"))


def test_policies_are_shipped():
    assert len(REPORTS) >= 8


@pytest.mark.parametrize("report", REPORTS, ids=lambda p: str(p.parent.parent.relative_to(ROOT / "assets")))
def test_shipped_policy_loads_and_drives(report):
    metrics = json.loads(report.read_text())
    run = report.parent.parent
    assert (run / "README.md").exists() or (run.parent / "README.md").exists()
    policy = load_policy(run)
    assert policy.env_id == metrics["env_id"]
    assert policy.env_overrides == metrics["trained_on"]
    assert 0.0 <= metrics["success_rate"] <= 1.0
    env = policy.make_env()
    table = run_episodes(env, policy, 1, seed=metrics["seed"])
    assert len(set(table["car"].tolist())) == env.config.num_cars
    assert table["decision"].max() <= env.config.horizon
