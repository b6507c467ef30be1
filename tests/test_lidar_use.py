"""``box2d-driving lidar-use``: whether an actor's LiDAR features move with what it sees."""

from __future__ import annotations

import json

import pytest

pytest.importorskip("torch")

from training.evaluation.lidar_use import lidar_use, main


def test_a_dead_encoder_is_blind_and_the_paper_codes_is_not(tmp_path):
    # the shipped 4-car lights policy (our ReLU encoder): its last ReLU is zero on every observation
    dead = lidar_use("traffic_lights_4cars", episodes=2)
    assert dead.encoder == "relu" and dead.decisions > 0
    assert dead.blind and dead.actions_changed == 0.0
    # a policy with the paper code's linear encoder, however little trained, sees
    from tests.helpers import tiny_train_config
    from training.trainers.trainer import train

    train(tiny_train_config(lidar_encoder="original"), tmp_path / "run")
    alive = lidar_use(str(tmp_path / "run"), episodes=2)
    assert alive.encoder == "original" and not alive.blind and alive.feature_spread > 1e-4


def test_the_command_prints_a_row_per_policy_and_writes_json(tmp_path, capsys):
    assert main(["traffic_lights_4cars", "--episodes", "1", "--json", str(tmp_path / "use.json")]) == 0
    out = capsys.readouterr()
    assert "traffic_lights_4cars" in out.out and "1 of 1 blind" in out.err
    rows = json.loads((tmp_path / "use.json").read_text())
    assert rows[0]["blind"] is True and rows[0]["encoder"] == "relu"
    with pytest.raises(SystemExit):
        main([str(tmp_path / "nothing_here")])
    assert "nothing_here" in capsys.readouterr().err


def test_the_page_counts_blind_actors_per_grid_point_from_their_kept_measurements(tmp_path):
    from training.results.lidar_blind import blind_line

    trials = []
    for noise, seed, blind in (("0.25", 0, True), ("0.25", 1, False), ("0.5", 0, True), ("0.5", 1, True)):
        name = f"lights_lidar_noise={noise}_seed={seed}"
        trials.append({"trial": name, "status": "done", "lidar_noise": noise, "seed": seed})
        kept = tmp_path / "weights" / "grid" / name
        kept.mkdir(parents=True)
        (kept / "model.safetensors").write_bytes(b"")  # measured already: the file beside it is read
        (kept / "lidar_use.json").write_text(json.dumps({"encoder": "relu", "decisions": 100, "blind": blind,
                                                         "feature_spread": 0.0 if blind else 0.02,
                                                         "actions_changed": 0.0 if blind else 0.1}))
    trials.append({"trial": "lights_lidar_noise=0.5_seed=2", "status": "stopped", "lidar_noise": "0.5", "seed": 2})
    line = blind_line({"path": str(tmp_path / "grid.json"), "trials": trials}, ["lidar_noise"])
    assert line is not None and line.endswith("lidar_noise 0.25: 1 of 2 blind; lidar_noise 0.5: 2 of 2 blind.")
    assert blind_line({"path": str(tmp_path / "other.json"), "trials": trials}, ["lidar_noise"]) is None
    # a sweep at noise 1.0 sees nothing by design, and says so
    noise1 = blind_line({"path": str(tmp_path / "grid.json"), "trials": trials[:2],
                         "sweep": {"fixed": {"lidar_noise": "1.0"}}}, [])
    assert noise1 is not None and "1 of 2 blind (at LiDAR noise 1.0 every ray is dropped" in noise1


def test_the_page_says_whether_the_policy_a_fine_tune_starts_from_is_blind(tmp_path):
    """A blind starting policy (a dead unit stays dead) is said, and whether the trials' own
    actors were kept to tell; a policy whose features vary, or no ``init_from``, says no more."""
    from training.results.lidar_blind import start_line

    def start(name, spread):
        folder = tmp_path / name
        folder.mkdir()
        (folder / "model.safetensors").write_bytes(b"")  # measured already: the file beside it is read
        (folder / "lidar_use.json").write_text(json.dumps({"encoder": "relu", "decisions": 100,
                                                           "feature_spread": spread, "actions_changed": 0.0}))
        return {"sweep": {"fixed": {"init_from": str(folder)}}}

    blind = start("blind", 1.2e-5)
    line = start_line(blind, kept=0)
    assert line is not None and "**blind**" in line and "1.2e-05" in line and "is not known" in line
    assert "measured below" in start_line(blind, kept=3)
    seeing = start_line(start("seeing", 8.7e-3), kept=0)
    assert seeing is not None and "features vary" in seeing and "blind" not in seeing
    assert start_line({"sweep": {"fixed": {}}}, kept=0) is None
    scratch = start_line({"sweep": {"fixed": {"lidar_encoder": "relu"}}}, kept=0)
    assert scratch is not None and "from scratch with our LiDAR encoder" in scratch and "not known" in scratch
    assert start_line({"sweep": {"fixed": {"lidar_encoder": "relu"}}}, kept=2) is None  # counted below
    assert start_line({"sweep": {"fixed": {"lidar_encoder": "original"}}}, kept=0) is None
    assert start_line({"sweep": {"fixed": {"init_from": str(tmp_path / "gone")}}}, kept=0) is None
