"""Scenario records: every table of the package read from them, registration and its errors,
scenario-declared sat-nav fields, reward terms and rollout columns."""

from types import SimpleNamespace

import gymnasium as gym
import numpy as np
import pytest

import box2d_driving
from box2d_driving import ConfigError, scenarios
from box2d_driving.envs.intersection import IntersectionEnv
from box2d_driving.metrics.rollouts import run_episodes
from box2d_driving.policies.scripted import make_policy
from box2d_driving.scenarios import Scenario, SingleAgent, register, scenario
from tests.helpers import HANG

SHIPPED = ("intersection-v0", "highway-v0", "crosswalk-v0", "intersection-spline-v0", "highway-spline-v0",
           "real-junction-v0")


@pytest.fixture
def fresh_registry(monkeypatch):
    """Registrations made by a test vanish after it (the Gymnasium ids too)."""
    monkeypatch.setattr(scenarios, "_REGISTERED", dict(scenarios._REGISTERED))
    monkeypatch.setattr(gym.envs.registration, "registry", dict(gym.registry))
    monkeypatch.setattr(gym, "registry", gym.envs.registration.registry)


def test_the_shipped_scenarios_are_records_in_order():
    assert tuple(box2d_driving.registry()) == SHIPPED
    gym_ids = {s.single_agent.gym_id for s in scenarios.scenarios().values() if s.single_agent}
    assert gym_ids == {"box2d_driving/Intersection-v0", "box2d_driving/Highway-v0", "box2d_driving/Crosswalk-v0",
                       "box2d_driving/RealJunction-v0"} and gym_ids <= set(gym.registry)


@pytest.mark.parametrize("env_id", SHIPPED)
def test_each_record_measures_the_metrics_its_curve_names(env_id):
    record = scenario(env_id)
    env = box2d_driving.make(env_id, num_cars=2)
    assert isinstance(env, record.env_class)
    table = run_episodes(env, make_policy("full-throttle", env), 2, seed=1_000_000_000)
    got = record.measure(table, env.config)
    assert tuple(got)[:len(record.curve())] == record.curve()  # success, collisions, then the rule's, in order
    assert all(isinstance(v, float) for v in got.values())
    figures = record.figures(table, env.config)
    assert (record.figure_data is None) == (figures == {})
    for name in record.baselines:  # every named baseline drives this scenario
        make_policy(name, env).act({a: np.zeros(env.observation_space(a).shape, np.float32) for a in env.agents})


def test_a_registered_scenario_is_an_env_id_everywhere(fresh_registry):
    from training.evaluation.checkpoint_curve import curve_metrics, rule_metrics
    from training.evaluation.figure_data import figure_data
    from training.evaluation.reports import report_for

    def fraction_arrived(table, config):
        return {"arrived_share": float(np.mean(table["arrived"]))}

    record = register(Scenario("mine-v0", IntersectionEnv, "a junction of my own", rule_metrics=fraction_arrived,
                               curve_metrics=("arrived_share",),
                               single_agent=SingleAgent("box2d_driving/Mine-v0", None, "rule")))
    assert box2d_driving.registry()["mine-v0"] == "a junction of my own"
    env = box2d_driving.make("mine-v0", num_cars=2)
    table = run_episodes(env, make_policy("rule", env), 1, seed=3)
    assert curve_metrics("mine-v0") == ("success_rate", "collision_rate", "arrived_share")
    assert set(rule_metrics("mine-v0", table, env.config)) == set(curve_metrics("mine-v0"))
    assert figure_data("mine-v0", table, env.config) == {}
    report = report_for("mine-v0")(table, env, None, None, 1, 3, None)  # no report of its own: outcomes + rule
    assert report["arrived_share"] == fraction_arrived(table, None)["arrived_share"] and "success_rate" in report
    single = gym.make("box2d_driving/Mine-v0")
    assert single.unwrapped.background_name == "rule"
    assert register(record) is record  # the same record again: nothing changes
    with pytest.raises(ConfigError, match="'mine-v0' is taken"):
        register(Scenario("mine-v0", IntersectionEnv, "another"))
    register(Scenario("mine-v0", IntersectionEnv, "another"), replace=True)
    assert box2d_driving.registry()["mine-v0"] == "another"


@pytest.mark.parametrize("kwargs,match", [
    ({"env_id": "mine"}, "versioned name"),
    ({"env": 3}, "env must be a callable or 'module:name'"),
    ({"rule_metrics": "no colon"}, "rule_metrics must be"),
    ({"curve_metrics": ("x",)}, "need rule_metrics"),
])
def test_a_bad_record_is_one_clear_error(kwargs, match):
    with pytest.raises(ConfigError, match=match):
        Scenario(**{"env_id": "mine-v0", "env": IntersectionEnv, "description": "d", **kwargs})


def test_an_unimportable_reference_names_the_scenario_and_field(fresh_registry):
    register(Scenario("ghost-v0", "no_such_module:Env", "nothing"))
    assert "ghost-v0" in box2d_driving.registry()  # listing imports nothing
    with pytest.raises(ConfigError, match="scenario ghost-v0: env 'no_such_module:Env' cannot be imported"):
        box2d_driving.make("ghost-v0")
    with pytest.raises(ConfigError, match="register: expected a Scenario"):
        register("ghost-v0")


def test_scenarios_of_installed_packages_come_from_entry_points(fresh_registry, monkeypatch):
    record = Scenario("plugged-v0", IntersectionEnv, "from a package")
    point = SimpleNamespace(name="plugged", value="pkg.mod:SCENARIO", load=lambda: record)
    monkeypatch.setattr(scenarios, "entry_points", lambda group: [point] if group == scenarios.ENTRY_POINTS else [])
    monkeypatch.setattr(scenarios, "_LOADED_ENTRY_POINTS", False)
    assert scenario("plugged-v0") is record

    def broken():
        raise ImportError("no module named pkg")

    monkeypatch.setattr(scenarios, "entry_points",
                        lambda group: [SimpleNamespace(name="broken", value="pkg.mod:SCENARIO", load=broken)])
    monkeypatch.setattr(scenarios, "_LOADED_ENTRY_POINTS", False)
    with pytest.raises(ConfigError, match="scenario entry point 'broken' .pkg.mod:SCENARIO. cannot be loaded"):
        scenarios.scenarios()


class _Extras(IntersectionEnv):
    """An intersection with one sat-nav value and one reward term of its own."""

    satnav_extras = ("one",)
    satnav_bounds = {"one": (0.0, 1.0)}
    reward_extras = ("toll",)
    scenario_info_fields = {"toll_paid": "the toll this decision (a number)"}

    def satnav_extra_values(self):
        return np.ones((self.config.num_cars, 1))

    def reward_extra_values(self, cars):
        return np.full((len(cars), 1), -0.25)

    def scenario_info(self, cars):
        return [{"toll_paid": 0.25} for _ in cars]


def test_scenario_satnav_fields_reward_terms_and_columns():
    env = _Extras(num_cars=2)
    assert env.observation_layout.satnav_fields[-1] == "one"
    obs, _ = env.reset(seed=0)
    assert env.observation_space("car_0").contains(obs["car_0"])
    obs, rewards, _, _, infos = env.step({a: 0 for a in env.agents})
    for agent, info in infos.items():
        terms = info["reward_terms"]
        assert list(terms)[-1] == "toll" and terms["toll"] == -0.25
        assert rewards[agent] == pytest.approx(sum(terms.values()), abs=1e-12)
    plain = IntersectionEnv(num_cars=2)
    plain.reset(seed=0)
    _, plain_rewards, _, _, _ = plain.step({a: 0 for a in plain.agents})
    assert rewards["car_0"] == pytest.approx(plain_rewards["car_0"] - 0.25, abs=1e-12)  # the same world, one toll
    table = run_episodes(_Extras(num_cars=2), make_policy("full-throttle", env), 1, seed=0)
    assert np.all(table["toll_paid"][table["decision"] > 0] == 0.25)


def test_a_satnav_field_without_bounds_or_a_wrong_term_count_is_named():
    class Unbounded(IntersectionEnv):
        satnav_extras = ("my_field",)

    with pytest.raises(ConfigError, match="'my_field' have no bounds; declare them in satnav_bounds"):
        Unbounded(num_cars=2)

    class Miscounted(_Extras):
        def reward_extra_values(self, cars):
            return np.zeros((len(cars), 2))

    env = Miscounted(num_cars=2)
    env.reset(seed=0)
    with pytest.raises(ValueError, match="gave 2 terms per car, reward_extras names 1"):
        env.step({a: 0 for a in env.agents})


def test_load_policy_and_train_from_the_top_level_package(tmp_path):
    numpy_policy = box2d_driving.load_policy("traffic_lights_4cars_noise05")
    torch_policy = box2d_driving.load_policy("traffic_lights_4cars_noise05", backend="torch")
    env = numpy_policy.make_env()
    obs, _ = env.reset(seed=5)
    assert numpy_policy.act(obs) == torch_policy.act(obs)
    model = box2d_driving.load_policy("traffic_lights_4cars_noise05", backend="sb3")
    from stable_baselines3 import PPO

    assert isinstance(model, PPO)
    with pytest.raises(ConfigError, match="backend must be 'numpy', 'torch' or 'sb3'"):
        box2d_driving.load_policy("traffic_lights_4cars_noise05", backend="jax")
    from training.trainers.trainer import RunError

    with pytest.raises(RunError, match="unknown setting.*batch_size.*batch_decisions"):
        box2d_driving.train("intersection-v0", tmp_path / "run", decisions=10, batch_size=3)


def test_each_records_trainer_is_a_behaviour_that_trains_its_env_id():
    import importlib
    from importlib.metadata import entry_points

    from box2d_driving.plugins import COMMANDS, behaviours

    trainers = {s.trainer: env_id for env_id, s in scenarios.scenarios().items() if s.trainer}
    assert sorted(trainers) == behaviours()
    for ep in entry_points(group=COMMANDS):
        if ep.name.startswith("train:"):
            module = importlib.import_module(ep.value.split(":")[0])
            assert module.ENV_ID == trainers[ep.name.split(":", 1)[1]], ep.name


def test_training_defaults_are_declared_once():
    import dataclasses

    from training.behaviours.scripts import BilevelArgs, ScriptArgs
    from training.trainers.bilevel import BilevelConfig
    from training.trainers.trainer import TrainConfig

    for args, config in ((ScriptArgs, TrainConfig), (BilevelArgs, BilevelConfig), (BilevelArgs, TrainConfig)):
        shared = {f.name for f in dataclasses.fields(args)} & {f.name for f in dataclasses.fields(config)}
        assert len(shared) >= 5, (args, config)
        for name in shared - {"ent_coef", "lidar_encoder", "value_targets"}:  # None on the CLI: a preset's applies
            assert getattr(args(), name) == getattr(config(), name), (args.__name__, name)
    from training.behaviours.scripts import config_from

    assert config_from("intersection-v0", ScriptArgs()).ent_coef == TrainConfig().ent_coef
    assert config_from("intersection-v0", ScriptArgs()).lidar_encoder == TrainConfig().lidar_encoder
    assert config_from("intersection-v0", ScriptArgs()).value_targets == TrainConfig().value_targets


@pytest.mark.parametrize("env_id", scenarios.scenarios())
def test_a_behaviour_trains_its_scenarios_default_world(env_id):
    """`make(ID)` and `train NAME` (and so a sweep) start from the same cars and LiDAR: the
    behaviour's CLI defaults are read from the scenario's config, not declared again."""
    from box2d_driving import plugins
    from training.sweeps.spec import script_module

    record = scenario(env_id)
    if record.trainer is None:
        pytest.skip(f"{record.env_id} has no trainer")
    assert record.trainer in plugins.behaviours()
    module = script_module(record.trainer)
    assert module.ENV_ID == record.env_id
    config = box2d_driving.make(record.env_id).config
    args = module.Args()
    assert (args.num_cars, args.lidar_noise) == (config.num_cars, config.lidar_noise)


def test_a_users_own_training_package_is_named_not_imported_in_ours(tmp_path):
    import subprocess
    import sys

    (tmp_path / "training").mkdir()
    (tmp_path / "training" / "__init__.py").write_text("raise RuntimeError('the user package ran')\n")
    python = ("import box2d_driving\n"
              "try:\n    box2d_driving.load_policy('traffic_lights_4cars', backend='torch')\n"
              "except Exception as exc:\n    print(type(exc).__name__, exc)\n")
    out = subprocess.run([sys.executable, "-c", python], cwd=tmp_path, capture_output=True, text=True, timeout=HANG)
    assert out.stdout.startswith("CommandMissing needs box2d-driving's training package"), out.stdout + out.stderr
    assert str(tmp_path / "training") in out.stdout and "the user package ran" not in out.stdout + out.stderr
    cli = subprocess.run([sys.executable, "-m", "box2d_driving", "train", "lights", "--help"], cwd=tmp_path,
                         capture_output=True, text=True, timeout=HANG)
    assert cli.returncode == 2 and "a folder of yours named training shadows it" in cli.stderr, cli.stderr


def test_a_baseline_that_is_no_scripted_policy_is_refused_at_registration(fresh_registry):
    with pytest.raises(ConfigError, match=r"baselines \['bold'\] are not scripted policies"):
        register(Scenario("mine-v0", IntersectionEnv, "d", baselines=("random", "bold")))
    assert "mine-v0" not in box2d_driving.registry()
