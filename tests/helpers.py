"""Hand-built worlds for physics and reward tests, hand-built rollout tables for metrics, and small
test utilities."""

from __future__ import annotations

import pathlib
from typing import Callable, Optional

import numpy as np

from box2d_driving.envs.base import DrivingEnv
from box2d_driving.metrics.rollouts import COLUMNS, OPTIONAL_COLUMNS
from box2d_driving.road.geometry import Path
from box2d_driving.road.layout import CarSpawn, Layout


class HandBuiltEnv(DrivingEnv):
    """A driving env whose layout comes from a function (for tests)."""

    metadata = {"name": "hand_built", "render_modes": [], "is_parallelizable": True}

    def __init__(self, make_layout: Callable[[np.random.Generator], Layout], **overrides):
        self._make_layout = make_layout
        super().__init__(**overrides)

    def build_layout(self, rng):
        return self._make_layout(rng)


def straight_car(start, end, **kw) -> CarSpawn:
    return CarSpawn(path=Path.straight(np.asarray(start, float), np.asarray(end, float)), **kw)


def layout(cars, edges=None, **kw) -> Layout:
    edges = np.zeros((0, 2, 2)) if edges is None else np.asarray(edges, float)
    return Layout(edges=edges, cars=list(cars), **kw)


def hand_env(cars, edges=None, layout_kw=None, **overrides) -> HandBuiltEnv:
    overrides.setdefault("num_cars", len(cars))
    lay = layout(cars, edges, **(layout_kw or {}))
    return HandBuiltEnv(lambda rng: lay, **overrides)


def level_index(env: DrivingEnv, accel: float) -> int:
    """Action index of an acceleration level."""
    return int(np.argmin(np.abs(np.asarray(env.config.accelerations) - accel)))


def table_from_rows(rows, names):
    """A rollout table from hand-written rows of the columns ``names`` (others zero)."""
    n = len(rows)
    t = {c: np.zeros(n) for c in COLUMNS + OPTIONAL_COLUMNS}
    t["collided_with"] = np.zeros(n, dtype=int)
    t["collision_partner"] = np.full(n, -1, dtype=int)
    t["partner_halted"] = np.zeros(n, dtype=bool)
    cols = list(zip(*rows))
    for name, col in zip(names, cols):
        t[name] = np.asarray(col)
    for name in ("episode", "car", "decision"):
        t[name] = t[name].astype(int)
    for name in ("in_junction", "arrived", "collided", "partner_halted"):
        t[name] = t[name].astype(bool)
    return t


def assert_nested_close(actual, expected, atol: float = 1e-6, where: str = "") -> None:
    """Equal structures (dicts, lists, strings, ints, bools) whose floats agree within ``atol``
    (NaN equals NaN, infinities must match exactly). For computed geometry and metrics, whose last
    bits can move between numpy / libosmium releases while a real change moves them far more.
    Names the first path that differs."""
    here = where or "<root>"
    if isinstance(expected, dict):
        assert isinstance(actual, dict), f"{here}: {type(actual).__name__} vs dict"
        assert actual.keys() == expected.keys(), f"{here}: keys {sorted(actual)} vs {sorted(expected)}"
        for key in expected:
            assert_nested_close(actual[key], expected[key], atol, f"{where}.{key}")
    elif isinstance(expected, (list, tuple)):
        assert isinstance(actual, (list, tuple)), f"{here}: {type(actual).__name__} vs list"
        assert len(actual) == len(expected), f"{here}: length {len(actual)} vs {len(expected)}"
        for i, (a, e) in enumerate(zip(actual, expected)):
            assert_nested_close(a, e, atol, f"{where}[{i}]")
    elif isinstance(expected, float) or isinstance(actual, float):
        assert not isinstance(actual, (bool, str)) and not isinstance(expected, (bool, str)), \
            f"{here}: {actual!r} vs {expected!r}"
        a, e = float(actual), float(expected)
        if np.isnan(e) or np.isinf(e):
            assert a == e or (np.isnan(a) and np.isnan(e)), f"{here}: {a!r} vs {e!r}"
        else:
            assert abs(a - e) <= atol, f"{here}: {a!r} vs {e!r} (differ by {abs(a - e):.3g} > {atol})"
    else:
        assert type(actual) is type(expected) and actual == expected, f"{here}: {actual!r} vs {expected!r}"


def tiny_train_config(**overrides):
    """A TrainConfig small enough for a test to train in seconds (2 cars, horizon 8, updates of
    80 decisions); ``overrides`` replace any field."""
    from training.trainers.trainer import TrainConfig

    base = dict(env_overrides={"num_cars": 2, "horizon": 8}, timesteps=320, n_envs=2,
                batch_decisions=80, minibatch=40, epochs=1, checkpoint_every=2, threads=1)
    base.update(overrides)
    return TrainConfig(**base)


def same_checkpoint_weights(a, b) -> bool:
    """Whether the run folders (or checkpoint files) ``a`` and ``b`` hold bit-identical policy
    weights: the same names, every tensor equal."""
    from training.runs.checkpoint import read_checkpoint

    wa, wb = read_checkpoint(a).policy, read_checkpoint(b).policy
    return wa.keys() == wb.keys() and all(np.array_equal(wa[k].numpy(), wb[k].numpy()) for k in wa)


def raised_in_a_thread(call: Callable[[], object]) -> list[Exception]:
    """The exceptions ``call`` raises when run in a thread other than the main one."""
    import threading

    caught: list[Exception] = []

    def run() -> None:
        try:
            call()
        except Exception as exc:
            caught.append(exc)

    worker = threading.Thread(target=run)
    worker.start()
    worker.join()
    return caught

# seconds: how long a test waits on a process before it calls it hung. A guard against a hang,
# never a speed limit: a correct program on a host other jobs keep busy must stay far inside it.
HANG = 1800


def rewrite_checkpoint(folder: "pathlib.Path", *, tensors: Optional[dict] = None, meta: Optional[dict] = None,
                       drop: str = "") -> "pathlib.Path":
    """Rewrite ``folder``'s ``model.safetensors`` in place: ``tensors`` replaced or added, the
    tensor ``drop`` removed, ``meta`` merged into its metadata (for hand-made hostile files)."""
    from safetensors import safe_open
    from safetensors.torch import load_file, save_file

    file = pathlib.Path(folder) / "model.safetensors"
    with safe_open(str(file), "pt") as fh:
        old_meta = fh.metadata()
    weights = {k: v for k, v in load_file(str(file)).items() if k != drop}
    weights.update(tensors or {})
    save_file(weights, str(file), metadata={**old_meta, **(meta or {})})
    return pathlib.Path(folder)


def slot_rollout(overrides: dict, n_envs: int, num_cpus: int, transport: str, steps: int = 30, seed: int = 5):
    """``steps`` steps of uniform random actions (generator seed 0) through a slot vector env of
    ``n_envs`` intersection instances: the observations (reset's first), rewards, dones and infos."""
    from training.ppo.vec_env import make_vec_env_from

    venv = make_vec_env_from("intersection-v0", overrides, n_envs, num_cpus, transport=transport)
    try:
        venv.seed(seed)
        obs = [venv.reset()]
        rng = np.random.default_rng(0)
        rewards, dones, infos = [], [], []
        for _ in range(steps):
            o, r, d, i = venv.step(rng.integers(0, 13, venv.num_envs))
            obs.append(o), rewards.append(r), dones.append(d), infos.append(i)
        return np.array(obs), np.array(rewards), np.array(dones), infos
    finally:
        venv.close()
