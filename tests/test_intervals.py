"""Rates with episodes as clusters (box2d_driving.metrics.intervals) and the fresh-block check of
the shipped policies (``box2d-driving check-shipped``)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from box2d_driving.metrics.intervals import RATES, Z95, clustered_share, pooled_rate_intervals, rate_intervals


def test_clustered_share_matches_a_hand_computation():
    # three episodes of two cars: hits 2, 0, 1 -> share 0.5; residuals 1, -1, 0; 3/2 * 2 = 3
    share, se, half = clustered_share(np.array([1, 1, 0, 0, 1, 0]), np.array([7, 7, 3, 3, 9, 9]))
    assert share == 0.5 and se == pytest.approx(math.sqrt(3) / 6) and half == pytest.approx(Z95 * math.sqrt(3) / 6)


def test_cars_that_fail_together_widen_the_interval_beyond_the_binomial():
    rng = np.random.default_rng(0)
    episodes = np.repeat(np.arange(200), 8)
    together = np.repeat(rng.random(200) < 0.3, 8)  # a whole episode fails or not
    apart = rng.random(1600) < 0.3  # every car on its own
    def binomial(p, n):
        return math.sqrt(p * (1 - p) / n)

    s1, se1, _ = clustered_share(together, episodes)
    s2, se2, _ = clustered_share(apart, episodes)
    assert se1 == pytest.approx(binomial(s1, 200), rel=0.02)  # 200 independent draws, not 1,600
    assert se2 == pytest.approx(binomial(s2, 1600), rel=0.15)  # independent cars: about the binomial


def test_clustered_share_edge_cases():
    assert all(math.isnan(x) for x in clustered_share(np.array([]), np.array([])))
    assert clustered_share(np.array([1, 0, 1]), np.array([4, 4, 4])) == (pytest.approx(2 / 3), 0.0, 0.0)
    with pytest.raises(ValueError, match="shape"):
        clustered_share(np.array([1, 0]), np.array([1]))


def test_rate_intervals_give_the_reports_rates():
    import box2d_driving
    from box2d_driving.metrics.lights import traffic_light_metrics
    from box2d_driving.metrics.rollouts import run_episodes
    from box2d_driving.policies.scripted import make_policy

    env = box2d_driving.make("intersection-v0", num_cars=4)
    table = run_episodes(env, make_policy("full-throttle", env), 12, seed=1_000_000_000)
    got = rate_intervals(table, RATES[:3])
    want = traffic_light_metrics(table)
    for name in RATES[:3]:
        assert got[name]["value"] == pytest.approx(want[name]) and got[name]["half_width"] > 0
    with pytest.raises(ValueError, match="no clustered interval"):
        rate_intervals(table, ("fifo_share",))


def _outcomes(episodes, arrived):
    """A rollout table of one decision per car: the cars of ``episodes[k]`` arrive as ``arrived[k]``."""
    episode = np.repeat(episodes, [len(a) for a in arrived])
    car = np.concatenate([np.arange(len(a)) for a in arrived])
    hit = np.concatenate([np.asarray(a, dtype=bool) for a in arrived])
    return {"episode": episode, "car": car, "decision": np.zeros(len(car), dtype=np.int64), "arrived": hit,
            "collided": ~hit}


def test_policies_on_the_same_episodes_pool_with_each_episode_one_cluster():
    # two policies on episodes 0-2 of two cars: A arrives 2, 0, 1 times, B 2, 1, 1; pooled per
    # episode 4, 1, 2 of 4 -> share 7/12, residuals 4-7/3, 1-7/3, 2-7/3 = 5/3, -4/3, -1/3
    a = _outcomes([0, 1, 2], [[1, 1], [0, 0], [1, 0]])
    b = _outcomes([0, 1, 2], [[1, 1], [1, 0], [0, 1]])
    pooled = pooled_rate_intervals([a, b], ("success_rate", "collision_rate"))
    se = math.sqrt(3 / 2 * ((5 / 3) ** 2 + (4 / 3) ** 2 + (1 / 3) ** 2)) / 12
    assert pooled["success_rate"]["value"] == pytest.approx(7 / 12)
    assert pooled["success_rate"]["se"] == pytest.approx(se)
    assert pooled["collision_rate"]["value"] == pytest.approx(5 / 12)
    assert pooled_rate_intervals([a], ("success_rate",)) == rate_intervals(a, ("success_rate",))
    # the same outcomes on six different episodes: the shared luck is gone, and so is its width
    apart = pooled_rate_intervals([a, _outcomes([3, 4, 5], [[1, 1], [1, 0], [0, 1]])], ("success_rate",))
    assert apart["success_rate"]["value"] == pytest.approx(7 / 12)
    assert apart["success_rate"]["se"] != pytest.approx(se)
    with pytest.raises(ValueError, match="no clustered interval"):
        pooled_rate_intervals([a], ("fifo_share",))


def test_check_shipped_sets_a_fresh_block_against_the_report(tmp_path, capsys):
    from training.evaluation import fresh_seeds

    name = "traffic_lights_4cars_noise05"
    report = fresh_seeds.shipped_reports()[name]
    rows = fresh_seeds.check_policy(report, fresh_seeds.FRESH_SEED, episodes=4)
    assert [r["metric"] for r in rows] == ["success_rate", "collision_rate", "red_light_violation_rate"]
    for r in rows:
        assert r["fresh_first_seed"] == fresh_seeds.FRESH_SEED and r["episodes"] == 4
        assert r["holds"] == (abs(r["z"]) <= Z95)
    # the reported block itself is refused (it would check nothing), as are seeds off the report range
    with pytest.raises(fresh_seeds.CheckError, match="overlap"):
        fresh_seeds.check_policy(report, 1_500_000_100, episodes=4)
    with pytest.raises(fresh_seeds.CheckError):
        fresh_seeds.check_policy(report, 10, episodes=4)
    assert fresh_seeds.main(["--only", "no_such_policy"]) == 2
    assert "no shipped policy no_such_policy" in capsys.readouterr().err
    status = fresh_seeds.main(["--only", name, "--episodes", "4", "--out", str(tmp_path / "check.md")])
    assert status in (0, 1)
    assert "| `traffic_lights_4cars_noise05` | success_rate |" in (tmp_path / "check.md").read_text()
    assert (tmp_path / "check.json").exists()


@pytest.mark.slow
def test_every_shipped_policy_holds_its_report_on_a_fresh_block():
    """The full check (about 5 minutes on two cores): every reported rate is reproduced on its own
    block, and on a fresh block none moves beyond chance (|z| > 3.3, p < 0.001) and at most one in
    seven moves beyond |z| 1.96 (about one in twenty is expected by chance)."""
    from training.evaluation import fresh_seeds

    rows = [r for report in fresh_seeds.shipped_reports().values()
            for r in fresh_seeds.check_policy(report, fresh_seeds.FRESH_SEED)]
    assert len(rows) >= 30 and all(r["reproduced"] for r in rows)
    assert max(abs(r["z"]) for r in rows) <= 3.3
    assert sum(not r["holds"] for r in rows) <= len(rows) / 7
