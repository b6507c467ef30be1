"""The shared-memory transport of the slot vector env's worker processes
(``training/ppo/shared_workers.py``): the same steps as in the learner's process and as
SuperSuit's transport, a car's full info at its end and the step columns in between, arrays the
next step cannot overwrite, and a failing or dying worker named instead of a hang."""

from __future__ import annotations

import os
import signal

import numpy as np
import pytest

pytest.importorskip("stable_baselines3")
pytest.importorskip("supersuit")

from tests.helpers import slot_rollout
from training.ppo.shared_workers import STEP_INFO_KEYS, SharedWorkers
from training.ppo.vec_env import make_vec_env_from

KW = {"num_cars": 3, "horizon": 6}


def _rollout(num_cpus: int, transport: str):
    return slot_rollout(KW, 4, num_cpus, transport)


def _equal(x, y) -> bool:
    if isinstance(x, np.ndarray):
        return np.array_equal(x, y)
    if isinstance(x, dict):
        return x.keys() == y.keys() and all(_equal(x[k], y[k]) for k in x)
    return x == y or (x != x and y != y)


@pytest.mark.parametrize("num_cpus", [1, 2, 4])
def test_same_steps_as_in_process_with_full_infos_at_each_cars_end(num_cpus):
    local, shared = _rollout(0, "shared"), _rollout(num_cpus, "shared")
    for a, b in zip(local[:3], shared[:3]):
        assert np.array_equal(a, b)
    ends = live = 0
    for step_local, step_shared, dones in zip(local[3], shared[3], local[2]):
        for slot, (x, y) in enumerate(zip(step_local, step_shared)):
            if not x:  # padding: nothing, as on every path
                assert y == {}
            elif dones[slot]:  # a car's end: the whole info, its terminal observation included
                assert "terminal_observation" in y and _equal(x, y)
                ends += 1
            else:  # any other live step: the step columns, with the in-process values
                assert set(y) == set(STEP_INFO_KEYS) and all(_equal(x[k], y[k]) for k in STEP_INFO_KEYS)
                live += 1
    assert ends and live


def test_same_steps_as_supersuits_transport():
    ours, theirs = _rollout(2, "shared"), _rollout(2, "supersuit")
    for a, b in zip(ours[:3], theirs[:3]):
        assert np.array_equal(a, b)


def test_returned_arrays_and_dicts_belong_to_their_step():
    venv = make_vec_env_from("intersection-v0", KW, 4, 2, transport="shared")
    try:
        venv.seed(3)
        venv.reset()
        rng = np.random.default_rng(1)
        first, rewards, _, infos1 = venv.step(rng.integers(0, 13, venv.num_envs))
        kept, kept_rewards = first.copy(), rewards.copy()
        _, _, _, infos2 = venv.step(rng.integers(0, 13, venv.num_envs))
    finally:
        venv.close()
    assert np.array_equal(first, kept) and np.array_equal(rewards, kept_rewards)
    assert not {id(i) for i in infos1} & {id(i) for i in infos2}
    assert len({id(i) for i in infos1}) == len(infos1)  # one dict per slot


def test_a_failing_worker_is_named_with_its_error_and_the_rest_closes():
    venv = make_vec_env_from("intersection-v0", KW, 4, 2, transport="shared")
    procs = list(venv._inner.procs)
    try:
        venv.seed(0)
        venv.reset()
        bad = np.zeros(venv.num_envs, dtype=np.int64)
        bad[-1] = 99  # no such action: the worker holding the last slot raises
        with pytest.raises(RuntimeError, match=r"env worker 1 failed: .*99"):
            venv.step(bad)
    finally:
        venv.close()
    assert not any(p.is_alive() for p in procs)


def test_a_dead_worker_is_named_instead_of_a_hang():
    venv = make_vec_env_from("intersection-v0", KW, 4, 2, transport="shared")
    try:
        venv.seed(0)
        venv.reset()
        os.kill(venv._inner.procs[0].pid, signal.SIGKILL)
        venv._inner.procs[0].join()
        with pytest.raises(RuntimeError, match=r"env worker 0 \(pid \d+\) died"):
            venv.step(np.zeros(venv.num_envs, dtype=np.int64))
    finally:
        venv.close()


def test_a_worker_that_cannot_build_its_envs_is_named_at_the_start():
    def broken():
        raise OSError("no map here")

    with pytest.raises(RuntimeError, match="env worker 0 failed: OSError: no map here"):
        SharedWorkers([broken], [3], 4)


def test_unknown_transport_is_refused_by_name():
    from box2d_driving.config import ConfigError
    from training.trainers.trainer import TrainConfig

    with pytest.raises(ValueError, match="transport must be one of shared, supersuit, got 'pipes'"):
        make_vec_env_from("intersection-v0", KW, 2, 1, transport="pipes")
    with pytest.raises(ConfigError, match="transport"):
        TrainConfig(transport="pipes")


def test_workers_started_by_spawn_step_as_forked_ones():
    """The default start method is fork on Linux, spawn on macOS and Windows: the shared buffers
    reach a spawned worker too, and its steps are the same."""
    import functools

    from supersuit.vector.constructors import call_wrap

    from training.ppo.vec_env import ConcatSlots, InstanceSlots, _make_env

    def run(start_method):
        fns = [functools.partial(InstanceSlots, functools.partial(_make_env, "intersection-v0", KW), k)
               for k in range(2)]
        probe = fns[0]()
        workers = SharedWorkers([call_wrap(ConcatSlots, fns)], [2 * probe.n_cars], probe.layout.size,
                                start_method=start_method)
        try:
            obs, _ = workers.reset(options={"slot_seed_base": 7})
            out = [obs]
            for a in range(4):
                workers.step_async(np.full(workers.num_envs, a, dtype=np.int64))
                out.append(workers.step_wait()[0])
            return np.array(out)
        finally:
            workers.close()
            probe.close()

    assert np.array_equal(run("fork"), run("spawn"))
