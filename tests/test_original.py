"""The paper's own code beside ours: its commands, the run carry, the rollout adapter and the
world-comparison statistics. CI has no sdriving install: the adapter is checked on a small
rollout recorded in sdriving 0.1.0 and committed (``tests/data/sdriving_rollout_rule.npz``: three
report episodes of the light rule, 4 cars, noise 0, made by ``sdriving_worker.py rollout``)."""

from __future__ import annotations

import importlib.util
import math
import json
import types
from pathlib import Path

import numpy as np
import pytest
import torch

from box2d_driving.metrics.rollouts import COLUMNS, OPTIONAL_COLUMNS, load_table
from box2d_driving.metrics.world_compare import SATNAV_STATISTICS, STATISTICS, agree, world_statistics
from training.original import cli
from training.original.commands import NOISE_EPOCHS, OriginalError, OriginalRun
from training.original.compare import comparison_rows, format_rows, ours_table

FIXTURE = Path(__file__).parent / "data" / "sdriving_rollout_rule.npz"


def _worker():
    spec = importlib.util.spec_from_file_location("sdriving_worker", cli.WORKER)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)  # imports nothing of sdriving at module level
    return module


# -- the original commands ------------------------------------------------------------------------
def test_noise_runs_are_the_original_commands():
    for noise, epochs in ((0.25, 75), (0.5, 75), (0.75, 75), (1.0, 50)):
        spec = OriginalRun(lidar_noise=noise).spec()
        assert spec["epochs"] == epochs
        assert spec["env"] == "MultiAgentRoadIntersectionFixedTrackDiscreteEnvironment"
        assert spec["env_kwargs"] == {"horizon": 250, "nagents": 4, "lidar_noise": noise, "history_len": 5,
                                      "timesteps": 10, "npoints": 100, "turns": False, "learn_right_of_way": False,
                                      "default_color": True, "balance_cars": True}
        assert spec["trainer"] == {"steps_per_epoch": 32000, "train_iters": 20, "pi_lr": 1e-3, "vf_lr": 1e-3,
                                   "entropy_coeff": 1e-4, "target_kl": 0.2, "gamma": 0.99, "lam": 0.97,
                                   "clip_ratio": 0.2}
        assert spec["ac_kwargs"] == {"hidden_sizes": [256, 256], "history_len": 5, "permutation_invariant": True}
    assert set(NOISE_EPOCHS) == {0.25, 0.5, 0.75, 1.0}
    json.dumps(OriginalRun(lidar_noise=0.25).spec())  # the worker reads it as JSON


def test_cars_are_balanced_as_the_original_commands_place_them():
    assert OriginalRun(lidar_noise=0.25).spec()["env_kwargs"]["balance_cars"] is True  # the noise runs
    assert OriginalRun(lidar_noise=0.0, epochs=1, nagents=8).spec()["env_kwargs"]["balance_cars"] is False
    assert OriginalRun(lidar_noise=0.0, epochs=1, nagents=8, balance_cars=True).balanced
    assert not OriginalRun(lidar_noise=0.25, balance_cars=False).balanced


@pytest.mark.parametrize("kwargs, field", [
    ({"lidar_noise": 0.3}, "give epochs"), ({"lidar_noise": 1.5}, "lidar_noise"),
    ({"lidar_noise": 0.25, "seed": -1}, "seed"), ({"lidar_noise": 0.25, "seed": True}, "seed"),
    ({"lidar_noise": 0.25, "epochs": 0}, "epochs"), ({"lidar_noise": 0.25, "nagents": 0}, "nagents"),
    ({"lidar_noise": 0.25, "balance_cars": "no"}, "balance_cars"),
])
def test_bad_settings_name_the_field(kwargs, field):
    with pytest.raises(OriginalError, match=field):
        OriginalRun(**kwargs)


def test_cli_refuses_bad_input_in_one_line(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("BOX2D_DRIVING_SDRIVING_VENV", str(tmp_path / "none"))
    assert cli.main(["train", "--lidar-noise", "0.25", "--out", str(tmp_path / "run")]) == 2
    assert "original setup" in capsys.readouterr().err
    assert not (tmp_path / "run").exists()  # nothing written before the environment is there
    fake = tmp_path / "venv" / "bin"
    fake.mkdir(parents=True)
    (fake / "python").write_text("")
    monkeypatch.setenv("BOX2D_DRIVING_SDRIVING_VENV", str(tmp_path / "venv"))
    busy = tmp_path / "busy"
    busy.mkdir()
    (busy / "keep.txt").write_text("mine")
    assert cli.main(["train", "--lidar-noise", "0.25", "--out", str(busy)]) == 2
    assert (busy / "keep.txt").read_text() == "mine" and not (busy / "run.json").exists()
    assert cli.main(["train", "--lidar-noise", "0.25", "--out", str(tmp_path / "new"), "--resume"]) == 2
    assert cli.main(["train", "--lidar-noise", "0.25", "--out", str(tmp_path / "x"), "--time-limit", "0"]) == 2
    assert cli.main(["compare", "--episodes", "0", "--out", str(tmp_path / "c")]) == 2
    assert cli.main(["compare", "--first-seed", "5", "--out", str(tmp_path / "c")]) == 2  # a training seed
    assert cli.main(["evaluate", "--run", str(busy), "--out", str(tmp_path / "m.json")]) == 2  # not a run
    lines = [line for line in capsys.readouterr().err.splitlines() if line]
    assert len(lines) == 6 and all("error:" in line for line in lines)
    assert not (tmp_path / "m.json").exists()


def test_resume_needs_the_same_settings(tmp_path):
    run = OriginalRun(lidar_noise=0.25)
    cli.prepare_folder(run, tmp_path / "r", resume=False)
    assert json.loads((tmp_path / "r" / "run.json").read_text()) == run.spec()
    cli.prepare_folder(run, tmp_path / "r", resume=True)
    with pytest.raises(OriginalError, match="other settings"):
        cli.prepare_folder(OriginalRun(lidar_noise=0.25, seed=1), tmp_path / "r", resume=True)


# -- the run carry ---------------------------------------------------------------------------------
def _fake_trainer(seed: int):
    torch.manual_seed(seed)
    pi, v = torch.nn.Linear(3, 2), torch.nn.Linear(3, 1)
    trainer = types.SimpleNamespace(ac=types.SimpleNamespace(pi=pi, v=v),
                                    pi_optimizer=torch.optim.Adam(pi.parameters(), lr=1e-3),
                                    vf_optimizer=torch.optim.Adam(v.parameters(), lr=1e-3),
                                    env=types.SimpleNamespace(cached_actions=None))
    for _ in range(3):  # give the optimisers state
        for net, opt in ((pi, trainer.pi_optimizer), (v, trainer.vf_optimizer)):
            opt.zero_grad()
            net(torch.randn(5, 3)).pow(2).sum().backward()
            opt.step()
    trainer.env.cached_actions = torch.tensor([[0.0, 1.5], [0.0, -0.25]])
    return trainer


def test_carry_restores_weights_optimisers_and_random_states(tmp_path):
    worker = _worker()
    a, b = _fake_trainer(0), _fake_trainer(1)
    np.random.seed(7)
    torch.manual_seed(8)
    worker.random.seed(9)
    worker.save_carry(str(tmp_path), a, {"epochs_done": 3})
    expected = (np.random.rand(), torch.rand(1).item(), worker.random.random())
    state = worker.load_carry(str(tmp_path), b)
    assert state["epochs_done"] == 3
    assert (np.random.rand(), torch.rand(1).item(), worker.random.random()) == expected
    for x, y in zip(a.ac.pi.state_dict().values(), b.ac.pi.state_dict().values()):
        assert torch.equal(x, y)
    for oa, ob in ((a.pi_optimizer, b.pi_optimizer), (a.vf_optimizer, b.vf_optimizer)):
        sa, sb = oa.state_dict()["state"], ob.state_dict()["state"]
        assert sa.keys() == sb.keys()
        for k in sa:
            assert all(torch.equal(sa[k][name], sb[k][name]) for name in sa[k])
    assert torch.equal(b.env.cached_actions, a.env.cached_actions)
    assert not list(tmp_path.glob("*.partial"))
    # the weights file is safetensors: no pickle anywhere in the carry
    assert (tmp_path / "weights.safetensors").read_bytes()[8:9] == b"{"
    # a learning-curve point: the actor alone
    from safetensors.torch import load_file

    path = worker.save_actor(str(tmp_path), a, 5)
    assert path.endswith("actors/epoch_0005.safetensors")
    kept = load_file(path)
    assert set(kept) == {f"actor.{k}" for k in a.ac.pi.state_dict()}


# -- the adapter: an sdriving rollout read as our table ---------------------------------------------
def test_sdriving_rollout_reads_as_our_table():
    table = load_table(FIXTURE)
    assert set(COLUMNS + OPTIONAL_COLUMNS) <= set(table)
    assert sorted(set(table["episode"].tolist())) == [0, 1, 2] and set(table["car"].tolist()) == {0, 1, 2, 3}
    assert table["decision"].max() == 25  # horizon 250 physics steps / 10 per decision
    # balance_cars: one car per approach in every episode
    for ep in range(3):
        first = (table["episode"] == ep) & (table["decision"] == 0)
        assert sorted(table["approach"][first].tolist()) == [0, 1, 2, 3]
    assert set(np.unique(table["light"]).tolist()) <= {0.0, 0.5, 0.75, 1.0}
    # an arrived car stays in the original: rows go on after its arrival, arrived stays true
    arrived_rows = table["arrived"] & (table["decision"] < 25)
    assert arrived_rows.any()
    stats = world_statistics(table)
    assert set(stats) == set(STATISTICS)
    assert stats["entries_per_car"]["value"] == 1.0 and stats["entries_per_car"]["units"] == 12
    assert stats["red_entry_share"]["value"] == 0.0  # the rule never enters on red here
    assert stats["collision_rate"]["value"] == 0.5
    assert stats["arrival_decision"]["value"] == pytest.approx(18.5)
    # what its cars read: heading errors to the goal below 0 before arriving (they drive left of
    # the axis), then minus the heading, due west -pi
    assert stats["heading_reading"]["value"] < 0
    assert 0 < stats["goal_reading"]["value"] < 0.1
    for name, value in (("east", 0.0), ("north", -math.pi / 2), ("west", -math.pi), ("south", math.pi / 2)):
        assert stats[f"arrived_heading_reading_{name}"]["value"] == pytest.approx(value, abs=1e-4)
    # our lights report reads it too; time to goal is each car's first arrival, not its last row
    report = cli.score_table(table)
    assert report["mean_time_to_goal"] == pytest.approx(18.5)
    assert report["red_light_violation_rate"] == 0.0 and report["junction_entries"] == 12
    assert report["intervals"]["collision_rate"]["value"] == 0.5


# -- the statistics on hand-built tables -----------------------------------------------------------
def _table(rows):
    names = ("episode", "car", "decision", "in_junction", "light", "arrived", "collided", "speed",
             "stop_line_distance")
    cols = {n: np.array([r[i] for r in rows]) for i, n in enumerate(names)}
    for n in ("in_junction", "arrived", "collided"):
        cols[n] = cols[n].astype(bool)
    for n in ("light", "speed", "stop_line_distance"):
        cols[n] = cols[n].astype(float)
    cols["x"] = cols["y"] = np.zeros(len(rows))
    return cols


def test_statistics_on_a_hand_built_table():
    rows = [  # episode, car, decision, in_junction, light, arrived, collided, speed, stop_line_distance
        (0, 0, 0, False, 1.0, False, False, 0.0, 10.0),
        (0, 0, 1, True, 0.75, False, False, 5.0, -2.0),   # entered on red, past its line at 5 m/s
        (0, 0, 2, False, 0.75, False, False, -3.0, 4.0),  # backed out
        (0, 0, 3, True, 0.75, True, False, 2.0, -1.0),    # entered again (on no light), arrived
        (0, 1, 0, False, 0.0, False, False, 0.0, 8.0),
        (0, 1, 1, False, 0.0, False, True, 4.0, 3.0),     # crashed before the junction
        (1, 0, 0, False, 0.5, False, False, 0.0, 8.0),
        (1, 0, 1, True, 0.75, False, False, 6.0, -1.0),   # entered on yellow
    ]
    s = world_statistics(_table(rows))
    assert "lidar_returns" not in s  # no LiDAR columns: left out
    assert s["entries_per_car"]["value"] == pytest.approx(3 / 3)
    assert s["red_entry_share"]["value"] == pytest.approx(1 / 3)
    assert s["yellow_entry_share"]["value"] == pytest.approx(1 / 3)
    assert s["later_entry_share"]["value"] == pytest.approx(1 / 3)
    assert s["arrival_rate"]["value"] == pytest.approx(1 / 3)
    assert s["arrival_decision"]["value"] == 3.0
    assert s["collision_rate"]["value"] == pytest.approx(1 / 3)
    assert s["stop_line_speed"]["value"] == pytest.approx((5.0 + 6.0) / 2)
    assert s["light_in_view"]["value"] == pytest.approx(4 / 8)


def test_satnav_statistics_on_a_hand_built_table():
    rows = [  # episode, car, decision, in_junction, light, arrived, collided, speed, stop_line_distance
        (0, 0, 0, False, 0.75, False, False, 0.0, 10.0),
        (0, 0, 1, False, 0.75, False, False, 8.0, 2.0),
        (0, 0, 2, False, 0.75, True, False, 8.0, -30.0),
        (0, 1, 0, False, 0.75, False, False, 0.0, 10.0),
        (0, 1, 1, False, 0.75, True, False, 8.0, -30.0),
        (1, 0, 0, False, 0.75, False, False, 0.0, 10.0),
        (1, 0, 1, False, 0.75, True, False, 8.0, -30.0),
    ]
    t = _table(rows)
    assert set(SATNAV_STATISTICS) <= set(STATISTICS)
    assert not set(SATNAV_STATISTICS) & set(world_statistics(t))  # no sat-nav columns: left out
    t["heading"] = np.array([np.pi, np.pi, -np.pi + 1e-7, np.pi / 2, np.pi / 2, 0.0, 0.0])
    t["satnav_heading"] = np.array([-0.1, -0.2, -np.pi, 0.3, -np.pi / 2, 0.0, 0.0])
    t["satnav_goal"] = np.array([0.01, 0.02, 1.0, 0.03, 1.0, 0.04, 1.0])
    s = world_statistics(t)
    assert s["heading_reading"]["value"] == pytest.approx((-0.1 - 0.2 + 0.3 + 0.0) / 4)  # before arriving
    assert s["goal_reading"]["value"] == pytest.approx((0.01 + 0.02 + 0.03 + 0.04) / 4)
    assert s["arrived_heading_reading_west"]["value"] == pytest.approx(-3.1416)  # heading just above -pi: west
    assert s["arrived_heading_reading_north"]["value"] == pytest.approx(-1.5708)
    assert s["arrived_heading_reading_east"]["value"] == 0.0
    assert s["arrived_heading_reading_south"]["units"] == 0
    # a reading on the other side of the cut is another value, not the same one
    flipped = dict(t, satnav_heading=np.where(t["satnav_heading"] == -np.pi, np.pi, t["satnav_heading"]))
    assert not agree(s["arrived_heading_reading_west"], world_statistics(flipped)["arrived_heading_reading_west"])


def test_agreement_is_the_interval_of_the_difference():
    assert agree({"value": 0.5, "half_width": 0.03}, {"value": 0.54, "half_width": 0.03})
    assert not agree({"value": 0.5, "half_width": 0.02}, {"value": 0.54, "half_width": 0.02})
    # every car at 4 m/s in both: float32's 3.9999995 (1.5, 1.5 and 1.0 m/s^2 in 0.1 s steps) agrees
    held = np.float32(0.0)
    for a in [1.5] * 20 + [1.0] * 10:
        held = np.float32(held + np.float32(a) * np.float32(0.1))
    held = float(held)
    assert held != 4.0 and agree({"value": held, "half_width": 0.0}, {"value": 4.0, "half_width": 0.0})
    assert not agree({"value": 3.9999, "half_width": 0.0}, {"value": 4.0, "half_width": 0.0})


def test_our_side_records_the_same_columns_and_compares():
    ours = ours_table("full-throttle", 2, 1_500_000_000, {"num_cars": 4})
    assert {"lidar_returns", "lidar_nearest"} <= set(ours)
    assert ((ours["lidar_returns"] >= 0) & (ours["lidar_returns"] <= 100)).all()
    finite = np.isfinite(ours["lidar_nearest"])
    assert ((ours["lidar_nearest"][finite] > 0) & (ours["lidar_nearest"][finite] <= 50)).all()
    rows = comparison_rows(ours, load_table(FIXTURE))
    assert [r["statistic"] for r in rows] == list(STATISTICS)
    text = format_rows("full-throttle", rows)
    assert text.count("\n") == len(STATISTICS) + 1


def test_the_constant_speed_driver_is_one_rule_in_both_worlds():
    """The worker's constant-speed actions (sdriving's speeds in m/s) and our policy's (the sat-nav's
    ``v / v_lim``) on the same hand-built speeds: the same levels, ties to the lower one."""
    from box2d_driving.policies.scripted import ConstantSpeedPolicy
    from box2d_driving.registry import make

    env = make("intersection-v0", preset="paper", num_cars=4)
    ours = ConstantSpeedPolicy(env)
    speed_at = env.observation_layout.newest("speed")
    speeds = np.array([0.0, 2.0, 3.875, 4.0, 4.1, 6.0, 8.0, -2.0, 3.0, 3.5])  # 3.875: (4 - v) / 1 s = 0.125, a tie
    observations = {}
    for k, v in enumerate(speeds):
        obs = np.zeros(env.observation_space("car_0").shape, dtype=np.float32)
        obs[speed_at] = v / env.config.v_lim
        observations[f"car_{k}"] = obs
    mine = ours.act(observations)
    levels = np.asarray(env.config.accelerations)
    theirs = _worker().constant_speed_actions(levels, speeds, np.full(len(speeds), 8.0), 1.0, 0.5)
    assert [mine[f"car_{k}"] for k in range(len(speeds))] == theirs.tolist()
    assert levels[theirs].tolist() == [1.5, 1.5, 0.0, 0.0, 0.0, -1.5, -1.5, 1.5, 1.0, 0.5]
    env.close()


def test_the_paper_preset_reads_its_sat_nav_as_the_original_recording_does():
    """The readings no statistic of motion sees (which side of the axis, an arrived car's
    heading error at the cut): the preset's against the committed sdriving recording."""
    ours = world_statistics(ours_table("rule", 3, 1_500_000_000, {"num_cars": 4}, "paper"))
    theirs = world_statistics(load_table(FIXTURE))
    for name in (f"arrived_heading_reading_{d}" for d in ("east", "north", "west", "south")):
        assert ours[name]["units"] > 0 and agree(ours[name], theirs[name]), name
    assert agree(ours["heading_reading"], theirs["heading_reading"])
    right = world_statistics(ours_table("rule", 3, 1_500_000_000, {"num_cars": 4, "drive_on": "right"}, "paper"))
    assert not agree(right["heading_reading"], theirs["heading_reading"])  # the mirror image reads the other sign


def test_both_worlds_must_place_cars_by_the_same_rule(tmp_path, monkeypatch, capsys):
    from training.original.compare import check_spawns

    check_spawns(4, {}, "paper")  # the preset's round robin is the 4-car runs' balance_cars=True
    check_spawns(8, {"approach_order": "random"}, "paper")  # the 8-car run's balance_cars=False
    check_spawns(8, {}, None)  # our default order has no counterpart: a listed difference
    with pytest.raises(OriginalError, match="approach_order=random"):
        check_spawns(8, {}, "paper")
    with pytest.raises(OriginalError, match="approach_order=rotate"):
        check_spawns(4, {"approach_order": "random"}, None)
    with pytest.raises(OriginalError, match="nagents"):
        check_spawns(0, {}, "paper")
    # through the command: one line, before either world runs or anything is written
    fake = tmp_path / "venv" / "bin"
    fake.mkdir(parents=True)
    (fake / "python").write_text("")
    monkeypatch.setenv("BOX2D_DRIVING_SDRIVING_VENV", str(tmp_path / "venv"))
    assert cli.main(["compare", "--cars", "8", "--preset", "paper", "--out", str(tmp_path / "c")]) == 2
    err = [line for line in capsys.readouterr().err.splitlines() if line]
    assert len(err) == 1 and "approach_order=random" in err[0]
    assert not (tmp_path / "c").exists()
    assert cli.section_name("paper", 4) == "paper" and cli.section_name("paper", 8) == "paper-8cars"
    assert cli.section_name(None, 4) == "default" and cli.section_name("paper-turns", 1) == "paper-turns-1car"


def test_a_kept_table_of_another_length_is_refused_not_read(tmp_path, monkeypatch, capsys):
    import shutil

    from training.original.compare import kept_table

    out = tmp_path / "c"
    out.mkdir()
    shutil.copy(FIXTURE, out / "original_rule.npz")  # 3 episodes
    assert len(np.unique(kept_table(out / "original_rule.npz", 3)["episode"])) == 3
    fake = tmp_path / "venv" / "bin"
    fake.mkdir(parents=True)
    (fake / "python").write_text("")
    monkeypatch.setenv("BOX2D_DRIVING_SDRIVING_VENV", str(tmp_path / "venv"))
    assert cli.main(["compare", "--drivers", "rule", "--episodes", "5", "--preset", "paper", "--out", str(out)]) == 2
    err = [line for line in capsys.readouterr().err.splitlines() if line]
    assert len(err) == 1 and "holds 3 episodes, not the 5" in err[0]
    assert sorted(p.name for p in out.iterdir()) == ["original_rule.npz"]  # nothing run or written
    monkeypatch.setattr(cli, "venv_python", lambda: Path("no-python"))
    monkeypatch.setattr("training.original.compare.ours_table", lambda *a, **k: load_table(FIXTURE))
    assert cli.main(["compare", "--drivers", "rule", "--episodes", "3", "--preset", "paper", "--out", str(out)]) == 0
    assert json.loads((out / "settings.json").read_text())["preset"] == "paper"
    assert cli.main(["compare", "--drivers", "rule", "--episodes", "3", "--out", str(out)]) == 2  # our defaults
    assert "drawn with" in capsys.readouterr().err and not (out / "ours_random.npz").exists()


def test_a_stopped_rollout_leaves_no_table_to_read_later(tmp_path, monkeypatch):
    import subprocess

    from box2d_driving.metrics.rollouts import save_table
    from training.original import compare as cmp

    def dies_midway(cmd, **kwargs):  # the worker writes part of its file, then is stopped
        Path(cmd[cmd.index("--out") + 1]).write_bytes(b"PK\x03\x04 half a zip")
        raise subprocess.CalledProcessError(-9, cmd)
    monkeypatch.setattr(cmp.subprocess, "run", dies_midway)
    out = tmp_path / "original_rule.npz"
    with pytest.raises(subprocess.CalledProcessError):
        cmp.original_table(Path("python"), Path("worker.py"), "rule", 3, 1_500_000_000, 4, out)
    assert not out.exists()
    save_table(load_table(FIXTURE), tmp_path / "t")  # numpy's rule: .npz added
    assert sorted(p.name for p in tmp_path.iterdir() if "partial" not in p.name) == ["t.npz"]
    assert len(np.unique(load_table(tmp_path / "t.npz")["episode"])) == 3


def test_the_page_section_takes_the_new_driver_tables_and_keeps_the_others(tmp_path):
    from training.original.compare import write_section

    def table(driver, value):
        return f"| {driver} | original | ours | agree |\n|---|---|---|---|\n| arrival_rate | {value} | {value} | yes |"

    page = tmp_path / "p.md"
    page.write_text(f"intro\n<!-- compare: paper -->\nold words\n\n{table('rule', 1)}\n\n{table('random', 2)}\n"
                    "<!-- /compare: paper -->\nafter\n")
    write_section(page, "paper", f"{table('random', 3)}\n\n{table('constant-speed', 4)}")
    tables = f"{table('constant-speed', 4)}\n\n{table('rule', 1)}\n\n{table('random', 3)}"
    assert page.read_text() == f"intro\n<!-- compare: paper -->\n{tables}\n<!-- /compare: paper -->\nafter\n"
    with pytest.raises(ValueError, match="no single section"):
        write_section(page, "default", table("rule", 5))
    assert "| 5 |" not in page.read_text()  # a refused write leaves the page as it was


def test_a_finished_run_carried_without_its_full_weights_is_scored_from_its_last_actor(tmp_path):
    from training.original.tables import latest_weights

    run = tmp_path / "run"
    (run / "actors").mkdir(parents=True)
    (run / "state.json").write_text(json.dumps({"epochs_done": 75}))
    (run / "weights.safetensors").write_bytes(b"x")
    assert latest_weights(run) == run / "weights.safetensors"  # resumable: its full weights
    (run / "weights.safetensors").unlink()
    assert latest_weights(run) == run / "actors" / "epoch_0075.safetensors"
    (run / "state.json").write_text("{")  # unreadable: the full weights asked for, reported missing
    assert latest_weights(run) == run / "weights.safetensors"


def test_a_curve_scores_every_kept_actor_once_on_one_set_of_selection_episodes(tmp_path, monkeypatch, capsys):
    from training.common.seeds import SELECTION

    run = tmp_path / "run"
    (run / "actors").mkdir(parents=True)
    (run / "run.json").write_text(json.dumps({"trainer": {"steps_per_epoch": 32000}}))
    for epoch in (5, 10):
        (run / "actors" / f"epoch_{epoch:04d}.safetensors").write_bytes(b"x")
    scored = []

    def fake_score(run_dir, weights, episodes, first_seed):  # the sdriving worker's part, stood in for
        scored.append((weights.name, episodes, first_seed))
        epoch = int(weights.stem.split("_")[1])
        return {"red_light_violation_rate": 0.5 - epoch / 100, "success_rate": 0.9, "collision_rate": 0.1}

    monkeypatch.setattr(cli, "score_actor", fake_score)
    monkeypatch.setattr(cli, "require_venv", lambda: None)
    assert cli.main(["curve", "--run", str(run), "--episodes", "3"]) == 0
    assert scored == [("epoch_0005.safetensors", 3, SELECTION.start), ("epoch_0010.safetensors", 3, SELECTION.start)]
    (run / "actors" / "epoch_0015.safetensors").write_bytes(b"x")
    assert cli.main(["curve", "--run", str(run), "--episodes", "3"]) == 0
    assert [s[0] for s in scored[2:]] == ["epoch_0015.safetensors"]  # the epochs drawn are kept, not redrawn
    import csv

    rows = list(csv.DictReader((run / "curve.csv").open()))
    assert [(int(r["epoch"]), int(r["joint_steps"])) for r in rows] == [(5, 160000), (10, 320000), (15, 480000)]
    assert float(rows[1]["red_light_violation_rate"]) == pytest.approx(0.4)
    before = (run / "curve.csv").read_text()
    capsys.readouterr()
    assert cli.main(["curve", "--run", str(run), "--episodes", "4"]) == 2  # other episodes: another curve
    assert cli.main(["curve", "--run", str(run), "--first-seed", "1500000000"]) == 2  # a report seed
    assert cli.main(["curve", "--run", str(tmp_path)]) == 2  # not a run folder
    err = [line for line in capsys.readouterr().err.splitlines() if line]
    assert len(err) == 3 and "one set of episodes" in err[0] and "run.json is missing" in err[2]
    assert (run / "curve.csv").read_text() == before


def _recorded_worker(monkeypatch) -> list:
    """The sdriving worker's rollouts stood in for by the recorded table (no sdriving needed);
    returns the list its commands are appended to."""
    import shutil

    calls: list = []

    def fake_worker(cmd, **kwargs):
        calls.append(cmd)
        shutil.copy(FIXTURE, cmd[cmd.index("--out") + 1])
    monkeypatch.setattr(cli, "require_venv", lambda: None)
    monkeypatch.setattr(cli.subprocess, "run", fake_worker)
    return calls


def test_a_report_names_its_weights_within_the_run_so_it_travels_with_it(tmp_path, monkeypatch):
    run = tmp_path / "scratch" / "noise1.0_seed1"
    (run / "actors").mkdir(parents=True)
    (run / "run.json").write_text("{}")
    (run / "state.json").write_text(json.dumps({"epochs_done": 50, "joint_steps": 1_600_000,
                                                "car_decisions": 5_900_000}))
    (run / "actors" / "epoch_0050.safetensors").write_bytes(b"x")
    calls = _recorded_worker(monkeypatch)
    out = run / "report.json"
    assert cli.main(["evaluate", "--run", str(run), "--episodes", "3", "--out", str(out)]) == 0
    report = json.loads(out.read_text())
    assert report["weights"] == "actors/epoch_0050.safetensors" and report["run"] == "noise1.0_seed1"
    assert str(tmp_path) not in out.read_text()  # nothing of where it was made
    assert (report["epochs"], report["joint_steps"], report["episodes"]) == (50, 1_600_000, 3)
    assert report["collision_rate"] == pytest.approx(0.5)  # scored from the table the worker wrote
    assert calls and str(run / "actors" / "epoch_0050.safetensors") in calls[0]


def test_evaluate_scores_a_scripted_driver_in_either_world_and_refuses_in_one_line(tmp_path, monkeypatch, capsys):
    import shutil

    specs: list = []

    def fake_worker(cmd, **kwargs):  # the recorded table stands in for sdriving's rollout
        specs.append((json.loads(Path(cmd[3]).read_text()), cmd[cmd.index("--driver") + 1]))
        shutil.copy(FIXTURE, cmd[cmd.index("--out") + 1])
    monkeypatch.setattr(cli, "require_venv", lambda: None)
    monkeypatch.setattr(cli.subprocess, "run", fake_worker)
    out = tmp_path / "drivers" / "full-throttle.json"
    assert cli.main(["evaluate", "--driver", "full-throttle", "--episodes", "3", "--out", str(out)]) == 0
    report = json.loads(out.read_text())
    (spec, driver), = specs
    assert driver == "full-throttle" and spec["env_kwargs"]["nagents"] == 4 and not spec["env_kwargs"]["turns"]
    assert spec["env_kwargs"]["lidar_noise"] == 0.0
    assert (report["driver"], report["cars_per_episode"], report["turns"], report["world"]) == \
        ("full-throttle", 4, False, "original")
    assert report["collision_rate"] == pytest.approx(0.5) and "run" not in report  # scored from the worker's table
    turning = tmp_path / "drivers" / "random-turns.json"
    assert cli.main(["evaluate", "--driver", "random", "--turns", "--episodes", "3", "--out", str(turning)]) == 0
    spec, driver = specs[1]
    assert driver == "random" and spec["env_kwargs"]["nagents"] == 1 and spec["env_kwargs"]["turns"]
    assert json.loads(turning.read_text())["cars_per_episode"] == 1
    ours = tmp_path / "ours.json"  # our side: the paper-turns preset, the same episodes
    assert cli.main(["evaluate", "--driver", "full-throttle", "--turns", "--world", "ours", "--episodes", "2",
                     "--out", str(ours)]) == 0
    mine = json.loads(ours.read_text())
    assert (mine["world"], mine["cars"], mine["junction_entries"]) == ("ours", 2, 2) and len(specs) == 2
    capsys.readouterr()
    bad = tmp_path / "bad.json"
    assert cli.main(["evaluate", "--run", str(tmp_path), "--cars", "2", "--out", str(bad)]) == 2
    assert cli.main(["evaluate", "--driver", "rule", "--epoch", "5", "--out", str(bad)]) == 2
    assert cli.main(["evaluate", "--driver", "rule", "--cars", "17", "--out", str(bad)]) == 2
    assert cli.main(["evaluate", "--driver", "rule", "--world", "ours", "--cars", "8", "--out", str(bad)]) == 2
    assert cli.main(["evaluate", "--driver", "rule", "--out", str(out)]) == 2  # nothing replaced
    assert cli.main(["evaluate", "--driver", "rule", "--world", "ours", "--set", "num_cars=2", "--out", str(bad)]) == 2
    err = [line for line in capsys.readouterr().err.splitlines() if line]
    assert len(err) == 6 and all("error:" in line for line in err)
    assert "need --driver" in err[0] and "--epoch" in err[1] and "nagents" in err[2]
    assert "approach_order=random" in err[3] and "exists" in err[4] and "--set num_cars" in err[5]
    assert not bad.exists() and len(specs) == 2 and json.loads(out.read_text()) == report


def test_both_worlds_pools_policies_on_their_shared_episodes_and_continues_a_stopped_folder(tmp_path, monkeypatch,
                                                                                           capsys):
    from box2d_driving.metrics.intervals import pooled_rate_intervals
    from box2d_driving.metrics.rollouts import load_table

    kept = Path(__file__).parents[1] / "assets" / "sweeps" / "weights" / "lights-paper-left-noise1"
    policies = [str(kept / "lights_seed=0"), str(kept / "lights_seed=1")]
    calls = _recorded_worker(monkeypatch)
    out = tmp_path / "both"
    argv = ["both-worlds", "--policy", *policies, "--episodes", "3", "--set", "integration=exact", "--out", str(out)]
    assert cli.main(argv) == 0
    assert len(calls) == 2 and "--out" in calls[0]  # one original-world table per policy
    report = json.loads((out / "report.json").read_text())
    for world in ("original", "ours"):
        tables = [load_table(out / f"lights_seed={s}_{world}.npz") for s in (0, 1)]
        want = pooled_rate_intervals(tables, ("red_light_violation_rate", "success_rate", "collision_rate"))
        for name, entry in want.items():
            assert report["pooled"][world][name] == pytest.approx(entry)
    ours = [load_table(out / f"lights_seed={s}_ours.npz") for s in (0, 1)]
    assert sorted(set(ours[0]["episode"].tolist())) == [0, 1, 2]
    assert not np.array_equal(ours[0]["acceleration"], ours[1]["acceleration"])  # two policies drove
    diff = report["original_minus_ours"]["collision_rate"]
    assert diff["value"] == pytest.approx(report["pooled"]["original"]["collision_rate"]["value"]
                                          - report["pooled"]["ours"]["collision_rate"]["value"])
    assert "| all | original minus ours |" in capsys.readouterr().out
    assert not list(out.glob("*.partial*"))
    # a second call reads the tables there instead of driving again; other episodes are refused
    assert cli.main(argv) == 0 and len(calls) == 2
    capsys.readouterr()
    assert cli.main([*argv[:-4], "--episodes", "4", "--out", str(out)]) == 2
    assert cli.main(["both-worlds", "--policy", policies[0], policies[0], "--out", str(tmp_path / "x")]) == 2
    assert cli.main(["both-worlds", "--out", str(tmp_path / "y")]) == 2
    err = [line for line in capsys.readouterr().err.splitlines() if line]
    assert len(err) == 3 and "drawn with" in err[0] and "two drivers named" in err[1] and "--policy" in err[2]
    assert not (tmp_path / "x").exists() and not (tmp_path / "y").exists()


def test_the_lone_car_run_is_the_original_command_on_its_turning_junction():
    from training.original.commands import LONE_CAR_EPOCHS, lone_car_run

    spec = OriginalRun(lidar_noise=0.0, **lone_car_run()).spec()
    assert spec["epochs"] == LONE_CAR_EPOCHS == 60
    assert spec["env_kwargs"] == {"horizon": 200, "nagents": 1, "lidar_noise": 0.0, "history_len": 5,
                                  "timesteps": 10, "npoints": 100, "turns": True, "learn_right_of_way": True,
                                  "default_color": True, "balance_cars": True}
    assert spec["trainer"]["entropy_coeff"] == 1e-3
    with pytest.raises(OriginalError, match="turns"):
        OriginalRun(lidar_noise=0.0, epochs=1, turns=1)  # type: ignore[arg-type]
