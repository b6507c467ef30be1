"""Property-based fuzzing of the public inputs (Hypothesis): random configs, actions, map files and
CLI flags either work, or raise the package's own error naming the culprit; never another
exception, a NaN, or an observation outside its space.

Examples are derandomised (the same ones every run, so CI cannot turn red by chance) and bounded
in number, so that the suite stays within its time budget; raise ``FUZZ_EXAMPLES`` to search
longer (``FUZZ_EXAMPLES=2000 python -m pytest tests/test_fuzz.py``).
"""

from __future__ import annotations

import json
import math
import os
from pathlib import Path

import numpy as np
import pytest

hypothesis = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings  # noqa: E402
from hypothesis import strategies as st  # noqa: E402

import box2d_driving  # noqa: E402
from box2d_driving import ActionError, ConfigError  # noqa: E402
from box2d_driving.maps import MapError, load_map  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = int(os.environ.get("FUZZ_EXAMPLES", "40"))
FUZZ = settings(max_examples=EXAMPLES, deadline=None, derandomize=True, database=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
ENV_IDS = list(box2d_driving.registry())
DEFAULTS = {env_id: box2d_driving.make(env_id).config for env_id in ENV_IDS}

# values of every kind: what a typo, a bad JSON file or a numpy pipeline hands over
WEIRD = st.one_of(
    st.sampled_from([float("nan"), float("inf"), -float("inf"), None, "", "big", "false", True, False,
                     -1, 0, 1, 2**70, -(2**70), 1e30, -1e-9, [], (), {}, [1, "x"], np.int64(3),
                     np.float32(0.5), np.bool_(True)]),
    st.integers(-10**6, 10**6),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=5),
)


def _near_default(value):
    """A plausible value of the default's kind: the default scaled, shifted or reshaped."""
    if isinstance(value, bool):
        return st.booleans()
    if isinstance(value, int):
        return st.integers(max(-5, value - 5), value * 3 + 5)
    if isinstance(value, float):
        return st.floats(-3.0, 3.0).map(lambda k: value * k if value else k)
    if isinstance(value, tuple) and value and all(isinstance(v, (int, float)) and not isinstance(v, bool)
                                                  for v in value):
        return st.lists(st.floats(-3.0, 3.0), min_size=len(value), max_size=len(value)).map(
            lambda ks: tuple(type(v)(v * k) if isinstance(v, float) else max(0, int(v * k))
                             for v, k in zip(value, ks)))
    return st.just(value)


@st.composite
def overrides(draw):
    env_id = draw(st.sampled_from(ENV_IDS))
    cfg = DEFAULTS[env_id]
    names = [n for n in cfg.field_names() if not n.startswith("render") and n != "map"]
    chosen = draw(st.lists(st.sampled_from(names), min_size=1, max_size=3, unique=True))
    out = {n: draw(st.one_of(_near_default(getattr(cfg, n)), WEIRD)) for n in chosen}
    return env_id, out


def _check_obs(env, obs):
    for agent, o in obs.items():
        assert np.all(np.isfinite(o)), agent
        assert env.observation_space(agent).contains(o), agent


@FUZZ
@given(overrides(), st.integers(0, 2**31 - 1))
def test_random_configs_run_or_name_the_field(case, seed):
    env_id, kw = case
    try:
        env = box2d_driving.make(env_id, **kw)
    except ConfigError as exc:
        assert any(name in str(exc) for name in kw) or "num_cars" in str(exc), (kw, str(exc))
        return
    rng = np.random.default_rng(seed)
    obs, _ = env.reset(seed=seed)
    _check_obs(env, obs)
    for _ in range(4):
        if not env.agents:
            break
        obs, rewards, *_ = env.step({a: int(rng.integers(env.action_space(a).n)) for a in env.agents})
        _check_obs(env, obs)
        assert all(math.isfinite(r) for r in rewards.values())
    env.close()


@FUZZ
@given(st.sampled_from(ENV_IDS), st.data())
def test_random_actions_step_or_name_the_agent(env_id, data):
    env = box2d_driving.make(env_id)
    env.reset(seed=data.draw(st.integers(0, 1000)))
    for _ in range(3):
        if not env.agents:
            return
        n = env.action_space(env.agents[0]).n
        actions = {a: data.draw(st.one_of(st.integers(0, n - 1), st.integers(0, n - 1).map(np.int32), WEIRD))
                   for a in env.agents}
        if data.draw(st.booleans()):
            actions[data.draw(st.sampled_from(["car_99", "nobody", "car_0"]))] = 0
        valid = (set(actions) == set(env.agents) and
                 all(isinstance(v, (int, np.integer)) and not isinstance(v, (bool, np.bool_)) and 0 <= v < n
                     for v in actions.values()))
        try:
            obs, rewards, *_ = env.step(actions)
        except ActionError as exc:
            assert not valid, (actions, exc)
            assert any(a in str(exc) for a in actions) or "dict" in str(exc), str(exc)
            return
        assert valid, actions
        _check_obs(env, obs)


MAP = json.loads((ROOT / "assets" / "maps" / "helsinki_25345669.json").read_text())


def _leaves(obj, path=()):
    if isinstance(obj, dict):
        for k, v in obj.items():
            yield from _leaves(v, path + (k,))
    elif isinstance(obj, list):
        for i, v in enumerate(obj):
            yield from _leaves(v, path + (i,))
    else:
        yield path


LEAVES = list(_leaves(MAP))


@FUZZ
@given(st.lists(st.tuples(st.sampled_from(LEAVES), WEIRD), min_size=1, max_size=3))
def test_broken_maps_are_one_map_error_naming_the_file(tmp_path_factory, edits):
    data = json.loads(json.dumps(MAP))
    for path, value in edits:
        node = data
        for key in path[:-1]:
            node = node[key]
        node[path[-1]] = value
    file = tmp_path_factory.mktemp("maps") / "m.json"
    # NaN and inf go in as JSON's NaN / Infinity, numpy scalars as numbers
    file.write_text(json.dumps(data, default=lambda o: o.item()))
    try:
        roadmap = load_map(file)
    except MapError as exc:
        assert str(file) in str(exc)
        return
    try:
        env = box2d_driving.make("real-junction-v0", map=str(file), num_cars=2)
    except ConfigError as exc:  # a readable map that cannot host two cars, or has no signals...
        assert "map" in str(exc) or "num_cars" in str(exc), str(exc)
        return
    obs, _ = env.reset(seed=0)
    _check_obs(env, obs)
    for _ in range(3):
        if not env.agents:
            break
        obs, *_ = env.step({a: 12 for a in env.agents})
        _check_obs(env, obs)
    assert roadmap.arms


FLAG_VALUES = st.one_of(st.sampled_from(["0", "-5", "1e9", "nan", "inf", "abc", "", "none", "True", "3.5", "2"]),
                        st.integers(-10, 10**6).map(str))


@FUZZ
@given(st.lists(st.tuples(st.sampled_from(["--threads", "--n-envs", "--epochs", "--timesteps", "--num-cars",
                                           "--lidar-noise", "--ent-coef", "--batch-decisions", "--seed",
                                           "--max-minutes", "--horizon", "--collision-reward", "--critic",
                                           "--num-cpus", "--device"]),
                          FLAG_VALUES), min_size=1, max_size=4))
def test_training_flags_parse_to_a_valid_config_or_exit_2(flags):
    """The training CLI up to the point a run would start: flags -> TrainConfig -> env check."""
    from training.common.cli_args import parse
    from training.behaviours.scripts import ScriptArgs, config_from

    argv = [x for pair in flags for x in pair]
    try:
        args = parse(ScriptArgs, argv)
    except SystemExit as exc:
        assert exc.code == 2
        return
    try:
        config = config_from("intersection-v0", args)
        box2d_driving.make(config.env_id, **config.env_overrides)
    except ConfigError as exc:
        assert "must" in str(exc) or "exceeds" in str(exc), str(exc)
        return
    assert (config.threads is None or config.threads >= 1) and config.n_envs >= 1 and config.epochs >= 1
    assert config.timesteps >= 0 and config.num_cpus >= 0


@FUZZ
@given(st.lists(st.tuples(st.sampled_from(["num_cars", "lidar_noise", "remove_collided", "accelerations",
                                           "horizon", "light_period_range", "nope"]),
                          st.one_of(FLAG_VALUES, st.sampled_from(["false", "(1, 2)", "[0.5]", "{}", "1" * 400,
                                                                  "[" * 200, "(-1.0, 1.0)"]))),
                min_size=1, max_size=3))
def test_render_set_overrides_build_an_env_or_name_the_field(pairs):
    from box2d_driving.cli import _parse_overrides

    kw = _parse_overrides([f"{k}={v}" for k, v in pairs])
    try:
        env = box2d_driving.make("intersection-v0", **kw)
    except ConfigError as exc:
        assert any(k in str(exc) for k in kw), str(exc)
        return
    env.reset(seed=0)


# JSON of every shape a hostile metadata field could hold
JSON_VALUES = st.recursive(
    st.one_of(st.none(), st.booleans(), st.integers(-2**70, 2**70), st.floats(allow_nan=True), st.text(max_size=4)),
    lambda inner: st.one_of(st.lists(inner, max_size=3), st.dictionaries(st.text(max_size=12), inner, max_size=3)),
    max_leaves=8)
META_FIELDS = ["counters", "optimizer_param_groups", "run_state"]


@FUZZ
@given(st.lists(st.tuples(st.sampled_from(META_FIELDS),
                          st.one_of(JSON_VALUES.map(json.dumps), st.text(max_size=8))), min_size=1, max_size=3))
def test_checkpoint_metadata_reads_or_is_one_checkpoint_error(tmp_path_factory, fields):
    """Any metadata: the torch reader returns a checkpoint or raises CheckpointError naming the file."""
    pytest.importorskip("torch")
    import shutil

    from box2d_driving.policies import CheckpointError
    from box2d_driving.policies.shipped import SHIPPED_POLICIES_DIR
    from tests.helpers import rewrite_checkpoint
    from training.runs.checkpoint import read_checkpoint

    folder = tmp_path_factory.mktemp("meta")
    shutil.copy(SHIPPED_POLICIES_DIR / "traffic_lights_4cars" / "model.safetensors", folder / "model.safetensors")
    rewrite_checkpoint(folder, meta=dict(fields))
    try:
        ckpt = read_checkpoint(folder)
    except CheckpointError as exc:
        assert "model.safetensors" in str(exc)
        return
    assert all(isinstance(v, int) and v >= 0 for v in ckpt.counters.values())
    assert ckpt.run_state is None or (math.isfinite(ckpt.run_state["wall_s"]) and ckpt.run_state["agent_steps"] >= 0)


@FUZZ
@given(st.sampled_from(["file", "missing/deep/x", "file/below"]), st.sampled_from(["--frames", "--out"]))
def test_render_output_paths_work_or_are_one_line(tmp_path_factory, where, flag):
    """Random output places for ``render``: written, or exit 2 with one line; never a traceback."""
    import io
    from contextlib import redirect_stderr

    from box2d_driving.cli import main as cli

    base = tmp_path_factory.mktemp("out")
    (base / "file").write_text("mine")
    target = base / where if flag == "--frames" else base / f"{where}.mp4"
    err = io.StringIO()
    with redirect_stderr(err):
        code = cli(["render", "highway-v0", "--episodes", "1", flag, str(target), "--set", "horizon=3"])
    assert code in (0, 2), err.getvalue()
    if code == 2:
        assert "Traceback" not in err.getvalue() and len(err.getvalue().strip().splitlines()) == 1
    assert (base / "file").read_text() == "mine"
