"""The env core steps several instances together exactly as each would step alone: observations,
rewards, terminations, truncations and infos bit for bit, for every scenario (the cases of the
golden fingerprints), through episode ends and resets, with the LiDAR of all instances in one
compiled call and with the Box2D reference backend."""

from __future__ import annotations

import numpy as np
import pytest

import box2d_driving
from box2d_driving.envs.core import step_instances
from tests.env_golden import CASES


def _same(a, b, where):
    if isinstance(a, dict):
        assert isinstance(b, dict) and list(a) == list(b), where
        for k in a:
            _same(a[k], b[k], f"{where}.{k}")
    elif isinstance(a, (tuple, list)):
        assert type(a) is type(b) and len(a) == len(b), where
        for k, (x, y) in enumerate(zip(a, b)):
            _same(x, y, f"{where}[{k}]")
    elif isinstance(a, np.ndarray):
        assert a.dtype == b.dtype and np.array_equal(a, b, equal_nan=True), where
    elif isinstance(a, float) and a != a:
        assert b != b, where
    else:
        assert type(a) is type(b) and a == b, where


def _run(env_id: str, overrides: dict, decisions: int, instances: int = 3, seed: int = 3):
    together = [box2d_driving.make(env_id, **overrides) for _ in range(instances)]
    alone = [box2d_driving.make(env_id, **overrides) for _ in range(instances)]
    for k in range(instances):
        together[k].reset(seed=seed + k)
        alone[k].reset(seed=seed + k)
    rng = np.random.default_rng(seed)
    n_actions = alone[0].action_space(alone[0].possible_agents[0]).n
    ended = 0
    for t in range(decisions):
        raws = [rng.integers(n_actions, size=len(e.agents)) for e in alone]
        decisions_ = step_instances(together, raws)
        for k, (env, d, raw) in enumerate(zip(alone, decisions_, raws)):
            agents = list(env.agents)
            obs, rew, term, trunc, infos = env.step(dict(zip(agents, raw.tolist())))
            where = f"decision {t}, instance {k}"
            assert [env.possible_agents[i] for i in d.cars.tolist()] == agents, where
            for j, a in enumerate(agents):
                _same(d.observations[j], obs[a], f"{where} {a} observation")
                _same(d.rewards[j].item(), rew[a], f"{where} {a} reward")
                _same(bool(d.terminated[j]), term[a], f"{where} {a} terminated")
                _same(bool(d.truncated and not d.terminated[j]), trunc[a], f"{where} {a} truncated")
                _same(d.infos[j], infos[a], f"{where} {a} infos")
            assert together[k].agents == env.agents, where
            if not env.agents:  # both start over, as a vector env's instance does
                ended += 1
                _same(together[k].reset(), env.reset(), f"{where} reset")
    return ended


@pytest.mark.parametrize("name,env_id,overrides", CASES, ids=[c[0] for c in CASES])
def test_instances_stepped_together_step_exactly_as_alone(name, env_id, overrides):
    assert _run(env_id, overrides, decisions=120) > 0  # episodes ended: resets were compared too


def test_together_with_the_box2d_lidar_backend():
    # every decision of both ways compared inside _run (too few decisions here for an episode to end)
    _run("crosswalk-v0", {"lidar_backend": "box2d", "num_cars": 3}, decisions=25, instances=2)


def test_one_instance_of_the_many_scenes_lidar_is_the_single_scene_kernel():
    """cast_rays_scenes over stacked scenes: each observer's rays as scene_segments + cast_rays
    of its own scene alone give them."""
    from box2d_driving.sensors import lidar

    rng = np.random.default_rng(0)
    n, rays = 4, 36
    pos = rng.uniform(-20, 20, (3 * n, 2))
    head = rng.uniform(-np.pi, np.pi, 3 * n)
    present = rng.random(3 * n) < 0.8
    peds = [rng.uniform(-10, 10, (m, 2)) for m in (0, 2, 1)]
    sizes = [rng.uniform(0.5, 1.0, m) for m in (0, 2, 1)]
    edges = [rng.uniform(-30, 30, (m, 4)) for m in (3, 0, 5)]
    observers = np.array([0, 2, 5, 6, 9, 11])
    got = lidar.cast_rays_scenes(pos, head, present, n, observers, 4.0, 2.0, np.concatenate(peds),
                                 np.concatenate(sizes), np.array([0, 2, 1]), np.concatenate(edges),
                                 np.array([3, 0, 5]), rays, 40.0)
    for row, obs in enumerate(observers):
        k, i = divmod(int(obs), n)
        s = slice(k * n, (k + 1) * n)
        segs, owner, one_sided = lidar.scene_segments(pos[s], head[s], present[s], 4.0, 2.0, peds[k], sizes[k],
                                                      edges[k])
        want = np.empty((1, rays))
        lidar.cast_rays(pos[s][[i]], head[s][[i]], np.array([i]), rays, 40.0, segs, owner, one_sided, want)
        np.testing.assert_array_equal(got[row], want[0])
    assert np.isfinite(got).any()
