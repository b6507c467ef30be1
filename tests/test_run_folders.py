"""Run and output folders are safe: nothing is written for a run that fails its checks, a signal
saves a checkpoint that --resume continues, and --overwrite / interruptions leave no stale or
half-written files."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytest.importorskip("torch")
pytest.importorskip("stable_baselines3")

import box2d_driving
from box2d_driving.policies import make_policy
from box2d_driving.render.video import record
from tests.helpers import tiny_train_config
from training.trainers.trainer import RunError, TrainConfig, train
from tests.helpers import HANG

ROOT = Path(__file__).resolve().parent.parent


def _tiny(**kw) -> TrainConfig:
    return tiny_train_config(**{"timesteps": 160, **kw})


def test_a_run_that_fails_its_checks_writes_nothing(tmp_path):
    out = tmp_path / "run"
    with pytest.raises(RunError, match="init-from"):
        train(_tiny(init_from=str(tmp_path / "missing")), out)
    assert not out.exists()
    with pytest.raises(ValueError, match="num_cars"):
        train(_tiny(env_overrides={"num_cars": 99}), out)
    assert not out.exists()
    train(_tiny(), out)  # the same folder then starts fresh
    assert json.loads((out / "state.json").read_text())["decisions"] == 160


@pytest.mark.skipif(sys.platform == "win32", reason="POSIX signals")
@pytest.mark.parametrize("signum", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_before_the_first_checkpoint_saves_one_that_resumes(tmp_path, signum):
    out = tmp_path / "run"
    argv = [sys.executable, "-m", "training.behaviours.traffic_lights", "--out", str(out), "--timesteps", "10000000",
            "--n-envs", "2", "--batch-decisions", "80", "--num-cars", "2", "--threads", "1", "--epochs", "1"]
    env = {**os.environ, "SDL_VIDEODRIVER": "dummy"}
    proc = subprocess.Popen(argv, cwd=ROOT, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    deadline = time.monotonic() + 120
    while not (out / "progress.csv").exists() or (out / "progress.csv").stat().st_size == 0:
        assert proc.poll() is None, proc.communicate()
        assert time.monotonic() < deadline, "training did not start"
        time.sleep(0.2)
    assert not (out / "model.safetensors").exists()  # no checkpoint yet (every 10 updates)
    proc.send_signal(signum)
    _, err = proc.communicate(timeout=HANG)
    assert proc.returncode == 128 + signum, err
    assert "interrupted" in err and "--resume" in err and "Traceback" not in err
    decisions = json.loads((out / "state.json").read_text())["decisions"]
    assert decisions > 0 and (out / "model.safetensors").exists()
    resumed = subprocess.run(argv[:6] + [str(decisions + 160)] + argv[7:] + ["--resume"], cwd=ROOT, env=env,
                             capture_output=True, text=True, timeout=HANG)
    assert resumed.returncode == 0, resumed.stderr
    assert json.loads((out / "state.json").read_text())["decisions"] >= decisions + 160


def test_evaluate_overwrite_replaces_the_folder_and_an_interrupted_one_leaves_it(tmp_path, monkeypatch):
    from training.evaluation import evaluate

    out = tmp_path / "eval"
    args = ["--checkpoint", "rule", "--episodes", "2", "--out", str(out)]
    assert evaluate.main(args) == 0
    (out / "stale_from_an_earlier_run.png").write_bytes(b"old")
    assert evaluate.main(args) == 2  # no --overwrite: refused, untouched
    assert (out / "stale_from_an_earlier_run.png").exists()
    assert evaluate.main(args + ["--overwrite"]) == 0
    assert not (out / "stale_from_an_earlier_run.png").exists() and (out / "metrics.json").exists()
    before = (out / "metrics.json").read_bytes()

    def interrupted(*a, **k):
        raise KeyboardInterrupt

    monkeypatch.setattr(evaluate, "run_episodes", interrupted)
    with pytest.raises(KeyboardInterrupt):
        evaluate.main(args + ["--overwrite"])
    assert (out / "metrics.json").read_bytes() == before  # the earlier report survives whole
    assert sorted(p.name for p in tmp_path.iterdir()) == ["eval"]  # no hidden partial folder


class _Interrupting:
    """A policy that is interrupted (Ctrl-C) at its ``after``-th decision."""

    def __init__(self, env, after: int) -> None:
        self.inner, self.after, self.calls = make_policy("rule", env), after, 0

    def act(self, obs):
        self.calls += 1
        if self.calls > self.after:
            raise KeyboardInterrupt
        return self.inner.act(obs)


def test_render_overwrite_and_interruption_leave_no_stale_or_partial_files(tmp_path):
    env = box2d_driving.make("intersection-v0", num_cars=2, render_mode="rgb_array", render_size=(64, 64))
    video, frames = tmp_path / "v.mp4", tmp_path / "frames"
    first = record(env, make_policy("rule", env), episodes=2, video=video, frames_dir=frames)
    second = record(env, make_policy("rule", env), episodes=1, video=video, frames_dir=frames, overwrite=True)
    assert second.frames < first.frames
    assert len(list(frames.iterdir())) == second.frames  # the longer first recording's frames are gone
    before = video.read_bytes()
    with pytest.raises(KeyboardInterrupt):
        record(env, _Interrupting(env, 3), episodes=1, video=video, frames_dir=frames, overwrite=True)
    assert video.read_bytes() == before and len(list(frames.iterdir())) == second.frames
    assert sorted(p.name for p in tmp_path.iterdir()) == ["frames", "v.mp4"]  # no *.partial*


def test_resume_compares_the_env_configs_the_overrides_make():
    """A setting added after a run started, given now at the value the run had by default, does
    not block its --resume; one that changes the world does, naming the key."""
    from types import SimpleNamespace

    from training.runs.run_dir import check_same_run

    before = {"horizon": 25, "arm_spawn_range": [0.2, 0.8], "drive_on": "left", "num_cars": 4}
    saved = {"env_id": "intersection-v0", "env_overrides": before, "critic": "mean"}

    def now(**extra):
        return SimpleNamespace(env_id="intersection-v0", critic="mean",
                               env_overrides={**before, "arm_spawn_range": (0.2, 0.8), **extra})

    check_same_run(saved, now())
    check_same_run(saved, now(integration="exact"))  # the default it ran with
    for extra in ({"integration": "euler"}, {"horizon": 30}, {"bogus": 1}):
        with pytest.raises(RunError, match="env_overrides differs"):
            check_same_run(saved, now(**extra))
    with pytest.raises(RunError, match="critic differs"):
        check_same_run(saved, SimpleNamespace(env_id="intersection-v0", critic="local", env_overrides=before))
