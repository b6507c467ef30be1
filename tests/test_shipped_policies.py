"""Every policy shipped under assets/policies loads, matches the settings its report says it was
evaluated with, and drives its scenario."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from box2d_driving.metrics.rollouts import run_episodes
from tests.helpers import assert_nested_close
from training.checkpoint import read_checkpoint
from training.inference import load_policy

ROOT = Path(__file__).resolve().parent.parent
# reports of a shipped policy (a run folder with its checkpoint; the communication study keeps the
# reports of runs whose policy is not shipped)
REPORTS = sorted(r for r in (ROOT / "assets" / "policies").glob("**/eval/metrics.json")
                 if (r.parent.parent / "model.safetensors").exists() or (r.parent.parent / "accel").is_dir())


def test_policies_are_shipped_safely():
    assert len(REPORTS) >= 8
    policies = ROOT / "assets" / "policies"
    # nothing shipped that unpickles or runs code when read
    assert not [p for p in policies.rglob("*") if p.suffix in (".zip", ".pkl", ".pt", ".pth", ".pickle")]
    for path in policies.rglob("model.safetensors"):
        read_checkpoint(path)  # a valid checkpoint of our format


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


# every report that kept its rollouts: a policy's eval/ and the other evaluations shipped beside it
# (other settings, e.g. eval_remove_collided/)
WITH_ROLLOUTS = sorted(r for r in (ROOT / "assets" / "policies").glob("**/metrics.json")
                       if (r.parent / "rollouts.npz").exists())


@pytest.mark.parametrize("report", WITH_ROLLOUTS, ids=lambda p: str(p.parent.relative_to(ROOT / "assets")))
def test_shipped_report_agrees_with_its_rollouts(report):
    """A report is the current metric code applied to its saved rollouts: a metric fix that is not
    followed by re-evaluating the shipped policies fails here."""
    import box2d_driving
    from box2d_driving.metrics.lights import outcome_rates
    from box2d_driving.metrics.right_of_way import fifo_metrics, safety_distance_metrics
    from box2d_driving.metrics.rollouts import load_table

    metrics = json.loads(report.read_text())
    table = load_table(report.parent / "rollouts.npz")
    for key, value in outcome_rates(table).items():
        assert metrics[key] == pytest.approx(value, nan_ok=True), key
    if metrics["env_id"] == "real-junction-v0":
        # evaluated as trained unless the report says otherwise (e.g. --remove-collided)
        cfg = box2d_driving.make(metrics["env_id"], **{**metrics["trained_on"], **metrics["env_config"]}).config
        assert metrics["right_of_way"] == pytest.approx(fifo_metrics(table))
        assert metrics["safety_distance"] == pytest.approx(safety_distance_metrics(
            table, cfg.a_max, cfg.car_length, wrecks_stay=cfg.wrecks_stay))
        if cfg.wrecks_stay:
            from box2d_driving.metrics.collisions import wreck_collision_room

            # nested and possibly NaN: compared as the report writes them (through JSON)
            assert_nested_close(metrics["wreck_collisions"], json.loads(json.dumps(
                wreck_collision_room(table, cfg.a_max, cfg.car_length))), atol=1e-9)
    if "collisions" in metrics:  # reports from before collision partners were recorded lack it
        from box2d_driving.metrics.collisions import collision_breakdown

        assert metrics["collisions"] == collision_breakdown(table)
