"""real-junction-v0: cars on real lanes and connectors, real signals, maps chosen by name or file."""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path

import numpy as np
import pytest

import box2d_driving
from box2d_driving.config import ConfigError
from box2d_driving.maps.shipped import get_map, shipped_maps
from box2d_driving.road.geometry import rectangle_corners, rectangles_overlap
from box2d_driving.road.lights import NO_LIGHT

FULL = 12  # index of +1.5 m/s^2


def test_every_shipped_map_is_a_default_and_loads():
    env = box2d_driving.make("real-junction-v0")
    assert set(env.config.map_names()) == set(shipped_maps())
    assert env.config.num_cars == 8 and env.config.horizon == 30 and env.config.v_lim == 8.0
    assert env.action_space("car_0").n == 13
    assert box2d_driving.make("real-junction-v0", communication=True).action_space("car_0").n == 26


def test_spawns_on_inbound_lanes_without_overlap_and_routes_through_a_connector():
    env = box2d_driving.make("real-junction-v0", num_cars=12)
    seen_maps = Counter()
    for seed in range(40):
        env.reset(seed=seed)
        lay, cfg = env.layout, env.config
        seen_maps[lay.name] += 1
        m = get_map(lay.name)
        boxes = []
        for car in lay.cars:
            (x, y), h = car.path.pose(0.0)
            boxes.append(rectangle_corners(x, y, float(h), cfg.car_length, cfg.car_width))
            assert not lay.in_junction(car.path.points[:1])[0]
            # the route ends at the end of an outbound lane
            ends = [m.lanes[k].centreline[-1] for k in range(len(m.lanes)) if m.lanes[k].direction == "out"]
            assert min(np.linalg.norm(e - car.path.points[-1]) for e in ends) < 1e-6
            assert lay.in_junction(car.path.points).any()
        for i in range(len(boxes)):
            for j in range(i + 1, len(boxes)):
                assert not rectangles_overlap(boxes[i], boxes[j]), f"seed {seed}: cars {i} and {j} overlap"
    assert len(seen_maps) == len(shipped_maps())  # one map per episode, sampled from the list


def test_a_lone_car_at_full_throttle_never_touches_an_edge():
    env = box2d_driving.make("real-junction-v0", num_cars=1, light_period_range=(100.0, 101.0))
    outcomes = Counter()
    for seed in range(200):
        obs, infos = env.reset(seed=seed)
        while env.agents:
            obs, _, _, _, infos = env.step({a: FULL for a in obs})
        outcomes[(infos["car_0"]["arrived"], infos["car_0"]["collided_with"])] += 1
    assert outcomes == Counter({(True, None): 200})


def test_each_car_sees_its_own_approach_light_before_the_stop_line():
    env = box2d_driving.make("real-junction-v0", num_cars=12)
    lay_seen = 0
    for seed in range(10):
        _, infos = env.reset(seed=seed)
        m = get_map(env.layout.name)
        for agent, car in zip(env.possible_agents, env.layout.cars):
            head = m.signal_for(car.approach)
            assert car.light_index == (-1 if head is None else head.id)
            d = infos[agent]["stop_line_distance"]
            if head is not None and 0 < d <= env.config.light_view_distance:
                assert infos[agent]["light"] != NO_LIGHT
                lay_seen += 1
    assert lay_seen > 0


def test_junction_area_is_the_map_polygon():
    env = box2d_driving.make("real-junction-v0", map="helsinki_25345669")
    env.reset(seed=0)
    m = get_map("helsinki_25345669")
    assert env.layout.in_junction(np.array([[0.0, 0.0], m.arms[0].centreline[-1]])).tolist() == [True, False]


def test_map_by_file_and_clear_errors(tmp_path):
    src = get_map("helsinki_25345669")
    path = src.save(tmp_path / "mine.json")
    env = box2d_driving.make("real-junction-v0", map=str(path), num_cars=4)
    env.reset(seed=1)
    assert env.layout.name == src.name
    with pytest.raises(ConfigError, match="unknown map 'nowhere'"):
        box2d_driving.make("real-junction-v0", map="nowhere")
    with pytest.raises(ConfigError, match="num_cars=99 exceeds"):
        box2d_driving.make("real-junction-v0", num_cars=99)
    bad = tmp_path / "bad.json"
    data = json.loads(path.read_text())
    data["lanes"][0]["arm"] = 77
    bad.write_text(json.dumps(data))
    with pytest.raises(ConfigError, match=r"lanes\[0\].arm"):
        box2d_driving.make("real-junction-v0", map=str(bad))
    with pytest.raises(ConfigError, match="spawn_spacing"):
        box2d_driving.make("real-junction-v0", spawn_spacing=3.0)


def test_same_seed_same_episode():
    def run(seed):
        env = box2d_driving.make("real-junction-v0", num_cars=10, lidar_noise=0.5)
        obs, _ = env.reset(seed=seed)
        rng = np.random.default_rng(0)
        trace = [np.concatenate([obs[a] for a in sorted(obs)])]
        while env.agents:
            obs, rewards, _, _, _ = env.step({a: int(rng.integers(13)) for a in env.agents})
            trace.append(np.concatenate([obs[a] for a in sorted(obs)] + [[rewards[a] for a in sorted(rewards)]]))
        return trace
    a, b = run(3), run(3)
    assert len(a) == len(b) and all(np.array_equal(x, y) for x, y in zip(a, b))


def test_cars_enter_the_junction_having_seen_their_light():
    from box2d_driving.metrics.lights import junction_entries
    from box2d_driving.metrics.rollouts import run_episodes
    from box2d_driving.policies import LightRulePolicy

    env = box2d_driving.make("real-junction-v0", num_cars=8)
    table = run_episodes(env, LightRulePolicy(env), 10, seed=0)
    entries = junction_entries(table)
    assert len(entries["light"]) > 40
    assert np.mean(entries["light"] != NO_LIGHT) > 0.95  # every approach of the shipped maps is signalled


def test_turn_signal_bits_are_recorded_and_measured():
    from box2d_driving.metrics.communication import communication_metrics
    from box2d_driving.metrics.rollouts import run_episodes
    from box2d_driving.policies import RandomPolicy

    env = box2d_driving.make("real-junction-v0", num_cars=8, communication=True)
    table = run_episodes(env, RandomPolicy(env, seed=0), 3)
    assert set(np.unique(table["bit_sent"][table["decision"] > 0])) <= {0.0, 1.0}
    m = communication_metrics(table)
    assert m["samples"] > 100 and 0.3 < m["bit_one_share"] < 0.7
    assert 0.0 <= m["speaker_consistency_bits"] < 0.1  # random bits say nothing (estimator bias only)


def test_report_adds_communication_and_the_unheard_control(tmp_path, capsys):
    pytest.importorskip("matplotlib")
    from box2d_driving.metrics.rollouts import run_episodes
    from box2d_driving.policies import RandomPolicy
    from training.evaluation.reports import real_junction_report

    def make_env(**kw):
        return box2d_driving.make("real-junction-v0", num_cars=4, communication=True, **kw)
    env = make_env()
    policy = RandomPolicy(env, seed=0)
    table = run_episodes(env, policy, 2, seed=0)
    metrics = real_junction_report(table, env, policy, tmp_path, 2, 0, make_env)
    assert 0.0 <= metrics["communication"]["bit_one_share"] <= 1.0
    assert set(metrics["messages_unheard"]) == {"success_rate", "collision_rate", "fifo_share", "safe_share"}
    assert (tmp_path / "safety_distance.png").exists()
    from training.evaluation.reports import add_collisions

    crashes = add_collisions({}, table, tmp_path)["collisions"]  # every collided car in one class
    assert crashes["collided_cars"] == int(table["collided"].sum()) > 0
    assert sum(k["cars"] for k in crashes["by_kind"].values()) == crashes["collided_cars"]
    assert (tmp_path / "collisions.png").exists()
    # the noise-level table reads such reports (two "levels" here: the same report twice)
    from training.evaluation import communication_table

    (tmp_path / "metrics.json").write_text(json.dumps(metrics))
    out = tmp_path / "communication.png"
    assert communication_table.main([f"0={tmp_path}", f"0.5={tmp_path}", "--out", str(out)]) == 0
    assert out.exists()
    # a level given twice (two training seeds): the per-level means table and the trend rows
    out.unlink()
    assert communication_table.main([f"0={tmp_path}", f"0={tmp_path}", f"0.5={tmp_path}", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "mean +- std" in printed and "| speaker consistency (bits) | 3 |" in printed
    assert out.exists()
    speeds = metrics["communication"]["by_bit"]
    assert speeds["0"]["share"] + speeds["1"]["share"] == pytest.approx(1.0)
    del metrics["communication"]["by_bit"]  # a report from before the per-bit profile: refused
    (tmp_path / "metrics.json").write_text(json.dumps(metrics))
    assert communication_table.main([f"0={tmp_path}", "--out", str(out)]) == 2
    # arguments it cannot read: one line naming the argument, no traceback
    capsys.readouterr()
    for bad, named in ((str(tmp_path), "expected NOISE=EVAL_FOLDER"), (f"half={tmp_path}", "'half="),
                       (f"0.5={tmp_path / 'none'}", "cannot read the evaluation report")):
        assert communication_table.main([bad, "--out", str(out)]) == 2
        err = capsys.readouterr().err
        assert named in err and err.count("\n") == 1 and "Traceback" not in err


def test_remove_collided_option_reaches_training_config_and_evaluation(tmp_path):
    pytest.importorskip("matplotlib")

    from training.evaluation import evaluate
    from training.behaviours.real_junction import Args
    from training.behaviours.scripts import config_from

    assert config_from("real-junction-v0", Args(remove_collided=True)).env_overrides["remove_collided"] is True
    assert "remove_collided" not in config_from("real-junction-v0", Args()).env_overrides
    ev = tmp_path / "ev"
    assert evaluate.main(["--checkpoint", "full-throttle", "--env-id", "real-junction-v0", "--num-cars", "8",
                          "--episodes", "3", "--out", str(ev), "--remove-collided"]) == 0
    m = json.loads((ev / "metrics.json").read_text())
    assert m["env_config"]["remove_collided"] is True
    assert m["collisions"]["collided_cars"] > 0  # full throttle crashes, yet no car meets a wreck
    assert m["collisions"]["by_kind"]["wreck"]["cars"] == 0
    assert m["safety_distance"]["closing_samples_halted_leader"] == 0
    assert "wreck_collisions" not in m


def test_evaluation_can_leave_wrecks_for_a_policy_trained_without_them(tmp_path):
    """--remove-collided is three-way: given, negated (--no-...), or absent (as trained)."""
    pytest.importorskip("torch")

    from training.evaluation import evaluate
    from training.common.cli_args import parse

    assert parse(evaluate.Args, ["--checkpoint", "x", "--out", "y"]).remove_collided is None
    assert parse(evaluate.Args, ["--checkpoint", "x", "--out", "y", "--remove-collided"]).remove_collided is True
    assert parse(evaluate.Args, ["--checkpoint", "x", "--out", "y", "--no-remove-collided"]).remove_collided is False
    policy = Path(__file__).resolve().parent.parent / "assets" / "policies" / "real_junction_8cars_remove_collided"
    runs = {}
    for name, flag in (("as_trained", []), ("wrecks_stay", ["--no-remove-collided"])):
        assert evaluate.main(["--checkpoint", str(policy), "--episodes", "1", "--out",
                              str(tmp_path / name), *flag]) == 0
        runs[name] = json.loads((tmp_path / name / "metrics.json").read_text())
    assert runs["as_trained"]["env_config"]["remove_collided"] is True
    assert "wreck_collisions" not in runs["as_trained"]
    assert runs["wrecks_stay"]["env_config"]["remove_collided"] is False
    assert "wreck_collisions" in runs["wrecks_stay"]  # the report asks wreck questions only when wrecks stay


def test_checkpoint_curve_evaluates_every_checkpoint_on_selection_seeds(tmp_path, capsys):
    import csv

    from tests.helpers import tiny_train_config
    from training.evaluation import checkpoint_curve
    from training.trainers.trainer import train

    run = tmp_path / "run"
    train(tiny_train_config(env_id="real-junction-v0", timesteps=320, checkpoint_every=2), run)
    assert checkpoint_curve.main([str(run), "--episodes", "1", "--seed", "10"]) == 2  # a training seed
    assert "selection seeds" in capsys.readouterr().err
    assert checkpoint_curve.main([str(run), "--episodes", "1"]) == 0
    rows = list(csv.DictReader((run / "checkpoint_curve" / "curve.csv").open()))
    kept = sorted(int(p.stem.split("_")[-1]) for p in (run / "checkpoints").glob("model_*.safetensors"))
    assert [int(r["decisions"]) for r in rows] == kept and len(kept) >= 2
    assert all(0 <= float(r["success_rate"]) <= 1 for r in rows)
    assert (run / "checkpoint_curve" / "curve.png").stat().st_size > 0
