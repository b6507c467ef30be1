"""Bad config values, training settings and CLI flags: one clear error of the package's own type
that names the culprit, and nothing written."""

from __future__ import annotations

import math

import numpy as np
import pytest

import box2d_driving
from box2d_driving import ConfigError
from box2d_driving.cli import _parse_overrides
from box2d_driving.cli import main as cli


@pytest.mark.parametrize("field, value, message", [
    ("remove_collided", "false", "remove_collided must be True or False"),
    ("remove_collided", 1, "remove_collided must be True or False"),
    ("collision_reward", float("nan"), "collision_reward must be a finite number"),
    ("collision_reward", "big", "collision_reward must be a finite number"),
    ("accelerations", 3, "accelerations must be a sequence"),
    ("accelerations", (0.0, math.inf), r"accelerations\[1\] must be a finite number"),
    ("lidar_range", math.inf, "lidar_range must be a finite number"),
    ("car_length", 1e300, "car_length must be a finite number"),
    ("substeps", 10**9, r"substeps must be an integer in \[1, 1000\]"),
    ("num_cars", 2.0, "num_cars must be an integer"),
    ("num_cars", True, "num_cars must be an integer"),
    ("spawn_jitter", -1.0, "spawn_jitter must be >= 0"),
    ("light_period_range", (12.0,), "light_period_range must be a sequence of 2 values"),
    ("render_size", (128, 1e9), r"render_size\[1\] must be an integer"),
])
def test_config_values_of_the_wrong_kind_name_the_field(field, value, message):
    with pytest.raises(ConfigError, match=message):
        box2d_driving.make("intersection-v0", **{field: value})


def test_numpy_values_are_plain_values():
    env = box2d_driving.make("intersection-v0", num_cars=np.int64(3), lidar_noise=np.float32(0.25),
                             remove_collided=np.bool_(True), accelerations=np.array([-1.0, 0.0, 1.0]))
    cfg = env.config
    assert (cfg.num_cars, cfg.remove_collided, cfg.accelerations) == (3, True, (-1.0, 0.0, 1.0))
    assert type(cfg.num_cars) is int and type(cfg.lidar_noise) is float


def test_cross_field_rules_name_every_field_involved():
    with pytest.raises(ConfigError, match=r"spawn_slot_spacing=.*spawn_jitter=.*car_length="):
        box2d_driving.make("highway-v0", spawn_jitter=4.0)
    with pytest.raises(ConfigError, match="spawn_slots"):
        box2d_driving.make("highway-v0", spawn_slots=3)


def test_cli_set_reads_true_and_false_as_booleans():
    assert _parse_overrides(["remove_collided=false", "render_lidar=True", "num_cars=8", "map=helsinki"]) == \
        {"remove_collided": False, "render_lidar": True, "num_cars": 8, "map": "helsinki"}


training = pytest.importorskip("training.trainers.trainer")


@pytest.mark.parametrize("field, value", [
    ("threads", 0), ("n_envs", 0), ("epochs", 0), ("timesteps", -5), ("learning_rate", float("nan")),
    ("gamma", 1.5), ("critic", "median"), ("seed", "one"), ("target_kl", -1.0), ("minibatch", 2.5),
])
def test_train_config_names_the_bad_field(field, value):
    with pytest.raises(ConfigError, match=f"TrainConfig: {field} must be"):
        training.TrainConfig(**{field: value})


@pytest.mark.parametrize("flags", [["--threads", "0"], ["--n-envs", "0"], ["--epochs", "0"],
                                   ["--timesteps", "-5"], ["--timesteps", "0"], ["--num-cars", "99"],
                                   ["--lidar-noise", "2"]])
def test_bad_training_flags_exit_2_and_write_nothing(tmp_path, capsys, flags):
    out = tmp_path / "run"
    assert cli(["train", "lights", "--out", str(out), *flags]) == 2
    err = capsys.readouterr().err
    assert "error:" in err and "Traceback" not in err and len(err.strip().splitlines()) == 1
    assert not out.exists()


def test_train_help_and_unknown_behaviour(capsys):
    assert cli(["train", "--help"]) == 0
    assert "lights" in capsys.readouterr().out
    assert cli(["train", "flying"]) == 2
    assert "flying" in capsys.readouterr().err


def test_cli_version_and_subcommand_usage_lines(capsys):
    with pytest.raises(SystemExit) as exc:
        cli(["--version"])
    assert exc.value.code == 0 and box2d_driving.__version__ in capsys.readouterr().out
    with pytest.raises(SystemExit) as exc:
        cli(["train", "lights", "--help"])
    out = capsys.readouterr().out
    assert exc.value.code == 0 and out.startswith("usage: box2d-driving train lights")
    assert all(line.count("(default") <= 1 for line in out.split("--"))  # said once per option
    assert "SPEC" not in out


@pytest.mark.parametrize("command", ["sweep", "reproduce", "evaluate"])
def test_every_delegated_command_answers_help_with_its_own_usage_line(capsys, command):
    with pytest.raises(SystemExit) as exc:
        cli([command, "--help"])
    assert exc.value.code == 0 and capsys.readouterr().out.startswith(f"usage: box2d-driving {command}")


def test_sweep_flags_are_checked_before_anything_is_written(tmp_path, capsys):
    out = tmp_path / "sweep"
    assert cli(["sweep", "lights", "--grid", "lidar_noise=0,x", "--out", str(out)]) == 2
    assert cli(["sweep", "lights", "--grid", "lidar_noise", "--out", str(out)]) == 2
    assert cli(["sweep", "lights", "--set", "threads=two", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("box2d-driving sweep: error:") >= 2 and "Traceback" not in err
    assert not out.exists()


@pytest.mark.parametrize("argv", [
    ["render", "nope-v0", "--out", "x.mp4"],
    ["train", "lights", "--n-envs", "0"],
    ["evaluate", "--seed", "5"],
    ["sweep", "lights", "--grid", "colour=red", "--out", "unused"],
    ["reproduce", "no_such_summary.json"],
    ["convert-checkpoint", "no_such_run"],
    ["play", "nope-v0"],
    ["list", "--bogus"],
    ["bench", "--bogus"],
    ["bench", "--train", "--bogus"],
    ["bench", "--memory", "--resets", "x"],
])
def test_every_command_reports_a_bad_input_in_one_line_with_status_2(tmp_path, monkeypatch, capsys, argv):
    monkeypatch.chdir(tmp_path)
    try:
        status = cli(argv)
    except SystemExit as exc:  # argparse's own usage errors exit through SystemExit
        status = exc.code
    assert status == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert err and err[-1].startswith(f"box2d-driving {argv[0]}") and ": error: " in err[-1], err
    assert not any(line.startswith("usage:") for line in err), err  # the error line alone, no usage dump
    assert not any("Traceback" in line for line in err)
    assert not list(tmp_path.iterdir())  # nothing written


@pytest.mark.parametrize("command", [
    ["render", "intersection-v0", "--episodes", "1", "--frames", "{file}"],
    ["render", "intersection-v0", "--episodes", "1", "--out", "{file}/x.mp4"],
    ["evaluate", "--checkpoint", "traffic_lights_4cars", "--episodes", "1", "--out", "{file}"],
    ["curve", "{file}"],
    ["train", "lights", "--timesteps", "80", "--out", "{file}"],
    ["train", "lights", "--timesteps", "80", "--out", "{file}/run"],
    ["import-osm", "{osm}", "--node", "1", "--out", "{file}/map.json"],
    ["import-osm", "{osm}", "--node", "1", "--out", "{dir}/map.json", "--png", "{file}/map.png"],
])
def test_an_output_path_that_cannot_be_written_is_one_line_and_leaves_nothing(tmp_path, capsys, command):
    """An output where a file stands in the way: exit 2, one line naming the path, nothing left."""
    from tests.osm_fixtures import four_way

    blocker = tmp_path / "afile"
    blocker.write_text("mine")
    (tmp_path / "dir").mkdir()
    osm = four_way(tmp_path / "four.osm")
    argv = [a.format(file=blocker, osm=osm, dir=tmp_path / "dir") for a in command]
    assert cli(argv) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and len(err.strip().splitlines()) == 1 and str(blocker) in err, err
    assert blocker.read_text() == "mine" and not list((tmp_path / "dir").iterdir())


def test_env_corners_are_our_errors_naming_the_culprit():
    import numpy as np

    from box2d_driving.config import ConfigError

    with pytest.raises(ConfigError, match=r"pedestrian_size must be in \[0.05, 10\] m"):
        box2d_driving.make("crosswalk-v0", pedestrian_size=1e-5)
    with pytest.raises(ConfigError, match="unknown map 'xxxx"):
        box2d_driving.make("real-junction-v0", map="x" * 300)  # longer than any file name may be
    spline = box2d_driving.make("intersection-spline-v0")
    with pytest.raises(ConfigError, match="reset: options must be a dict or None, got str"):
        spline.reset(seed=0, options="abc")
    env = box2d_driving.make("intersection-v0")
    first = env.reset(seed=np.int64(5))[0]  # a numpy integer is a seed like any other
    again = env.reset(seed=5)[0]
    assert all(np.array_equal(first[a], again[a]) for a in first)
    for bad in (True, -1, 2.5, "5"):
        with pytest.raises(ConfigError, match="reset: seed must be"):
            env.reset(seed=bad)
    import gymnasium as gym

    single = gym.make("box2d_driving/Intersection-v0").unwrapped
    single.reset(seed=np.int64(3))
    with pytest.raises(ConfigError, match="reset: seed must be"):
        single.reset(seed=True)


def test_a_first_compile_is_announced_at_a_terminal_only(monkeypatch, capsys, tmp_path):
    import io

    from box2d_driving import compile_note

    class Terminal(io.StringIO):
        def isatty(self):
            return True

    monkeypatch.setattr(compile_note, "_said", False)
    monkeypatch.setattr(compile_note, "kernels_cached", lambda: False)
    err = Terminal()
    monkeypatch.setattr("sys.stderr", err)
    compile_note.note_first_compile()
    compile_note.note_first_compile()  # once per process
    assert err.getvalue().count("compiling the simulator's kernels") == 1
    monkeypatch.setattr(compile_note, "_said", False)
    plain = io.StringIO()  # a log file or a pipe: nothing
    monkeypatch.setattr("sys.stderr", plain)
    compile_note.note_first_compile()
    assert plain.getvalue() == ""
    monkeypatch.undo()
    box2d_driving.make("intersection-v0").reset(seed=0)  # this checkout's cache is warm by now
    assert compile_note.kernels_cached()


def test_install_hints_fit_how_the_package_was_installed(monkeypatch, tmp_path):
    from box2d_driving import plugins

    assert plugins.install_hint("train") == 'pip install -c constraints-cpu.txt -e ".[train]"'  # this checkout
    fake = tmp_path / "site-packages" / "box2d_driving" / "plugins.py"  # a wheel: no setup.py above it
    fake.parent.mkdir(parents=True)
    monkeypatch.setattr(plugins, "__file__", str(fake))
    assert plugins.install_hint("osm") == 'pip install "box2d-driving[osm]"'


def test_bench_help_explains_every_option(capsys):
    with pytest.raises(SystemExit):
        cli(["bench", "--help"])
    out = capsys.readouterr().out
    assert "(default 5)" in out and "car counts to time" in out and "seed of the episodes" in out


def test_a_zero_dimensional_array_for_a_tuple_field_names_the_field():
    import numpy as np

    from box2d_driving.config import ConfigError

    with pytest.raises(ConfigError,
                       match=r"IntersectionConfig: accelerations must be a sequence of finite numbers, got array"):
        box2d_driving.make("intersection-v0", accelerations=np.array(1.0))
    with pytest.raises(ConfigError, match="crosswalk_x must be"):
        box2d_driving.make("crosswalk-v0", crosswalk_x=np.array(3.0))
