"""Run folders as transactions: one trainer per folder, ``--resume`` from wherever a kill left the
run, logs that never hold a stretch twice, and a full disk as one line.

Real training processes are killed with SIGKILL at chosen points: a small driver script wraps one
function of the trainer so that the process kills itself there (before the first checkpoint, in the
middle of writing a checkpoint, in the middle of copying it to the root, long after the last one)."""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from tests.helpers import HANG, tiny_train_config
from training.runs.lock import RunLockedError, run_lock
from training.runs.run_dir import RunError
from training.trainers.trainer import train

ROOT = Path(__file__).resolve().parents[1]
BUDGET = 480  # decisions: 6 updates of 80, checkpoints after updates 2, 4 and at the end

# The driver trains the tiny config in OUT, killing itself (SIGKILL) where KILL says.
_DRIVER = r"""
import os, shutil, signal, sys, time
from pathlib import Path
from tests.helpers import HANG, tiny_train_config
import training.runs.checkpoint as checkpoint
import training.runs.progress as progress
import training.runs.run_dir as run_dir
from training.trainers.trainer import train

kill, out, resume = sys.argv[1], Path(sys.argv[2]), sys.argv[3] == "resume"
die = lambda: os.kill(os.getpid(), signal.SIGKILL)
calls = {"n": 0}

if kill.startswith("after_rollout_"):  # after the Nth update's rollout (its row logged by then)
    n = int(kill.rsplit("_", 1)[1])
    original = progress.RolloutMetrics._on_rollout_end
    def on_rollout_end(self):
        original(self)
        calls["n"] += 1
        if calls["n"] == n:
            self.logger.dump(self.num_timesteps)  # the row a killed run had written
            die()
    progress.RolloutMetrics._on_rollout_end = on_rollout_end
elif kill.startswith("hold_until:"):  # after the first checkpoint, hold the folder until told
    release = Path(kill.split(":", 1)[1])
    original = progress.RolloutMetrics._on_rollout_end
    def on_rollout_end(self):
        original(self)
        calls["n"] += 1
        if calls["n"] == 3:
            (out / "holding").write_text("")
            while not release.exists():
                time.sleep(0.05)
            die()
    progress.RolloutMetrics._on_rollout_end = on_rollout_end
elif kill == "mid_write":  # the second checkpoint's kept copy half written
    original = checkpoint.write_bytes_atomic
    def write(path, data):
        calls["n"] += 1
        if calls["n"] == 2:
            path.with_name(path.name + ".partial").write_bytes(data[: len(data) // 2])
            die()
        original(path, data)
    checkpoint.write_bytes_atomic = write
elif kill == "mid_copy":  # the first checkpoint kept, its copy to the root half made
    def copyfile(src, dst):
        Path(dst).write_bytes(Path(src).read_bytes()[:1000])
        die()
    run_dir.shutil = type("patched", (), {"copyfile": staticmethod(copyfile)})
train(tiny_train_config(timesteps=int(sys.argv[4]), checkpoint_every=2), out, resume=resume)
print("trained")
"""


def _drive(kill: str, out: Path, resume: bool = False, budget: int = BUDGET) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-c", _DRIVER, kill, str(out), "resume" if resume else "new",
                           str(budget)], cwd=ROOT, capture_output=True, text=True, timeout=HANG,
                          env={**os.environ, "SDL_VIDEODRIVER": "dummy"})


def _logged_decisions(out: Path) -> list[float]:
    rows = []
    for path in [out / "progress.csv"] + sorted(out.glob("progress.resumed_*.csv")):
        with path.open() as fh:
            rows += [float(r["time/total_timesteps"]) for r in csv.DictReader(fh)]
    return rows


def _finished_cleanly(out: Path) -> None:
    assert json.loads((out / "state.json").read_text())["decisions"] == BUDGET
    logged = _logged_decisions(out)
    assert logged == sorted(set(logged)) and logged[-1] == BUDGET, logged  # each stretch once, forwards
    assert not list(out.rglob("*.partial")) and not (out / ".lock").exists()


@pytest.mark.parametrize("kill,resumes_at,cut", [
    ("after_rollout_1", None, None),          # before the first checkpoint: starts again
    ("mid_copy", 160, "model.safetensors replaced by checkpoints"),  # kept copy whole, root not
    ("mid_write", 160, "model_320.safetensors.partial"),  # the second checkpoint half written
    ("after_rollout_4", 160, "rows of progress.csv"),   # two updates past the checkpoint at 160
])
def test_a_run_killed_anywhere_resumes_from_its_newest_complete_checkpoint(tmp_path, kill, resumes_at, cut):
    out = tmp_path / "run"
    killed = _drive(kill, out)
    assert killed.returncode == -signal.SIGKILL, killed.stderr[-2000:]
    assert (out / "config.json").exists()
    # a fresh start on the folder is refused (it holds a run), and says what to do
    refused = _drive("none", out)
    assert refused.returncode == 1 and "not empty; choose another --out or pass --resume" in refused.stderr
    done = _drive("none", out, resume=True)
    assert done.returncode == 0 and "trained" in done.stdout, done.stderr[-3000:]
    if resumes_at is None:
        assert "stopped before its first one): starting it again" in done.stderr
        assert len(list(out.glob("events.out.tfevents.*"))) == 1  # the dead run's TensorBoard log went
        assert not list(out.glob("config.resumed_*.json"))
    else:
        assert f"resuming from the checkpoint at {resumes_at} decisions" in done.stderr and cut in done.stderr
        assert [p.name for p in out.glob("config.resumed_*.json")] == [f"config.resumed_{resumes_at:012d}.json"]
    _finished_cleanly(out)


def test_a_resumed_run_after_a_kill_matches_one_never_killed(tmp_path):
    """Resuming from the kept checkpoint after a kill mid-copy continues as a clean resume from
    the same checkpoint would: the same weights at the end, bit for bit."""
    from tests.helpers import same_checkpoint_weights

    killed, clean = tmp_path / "killed", tmp_path / "clean"
    assert _drive("mid_copy", killed).returncode == -signal.SIGKILL
    assert _drive("none", killed, resume=True).returncode == 0
    train(tiny_train_config(timesteps=160, checkpoint_every=2), clean)
    train(tiny_train_config(timesteps=BUDGET, checkpoint_every=2), clean, resume=True)
    assert same_checkpoint_weights(killed, clean)


def test_a_second_trainer_on_a_busy_folder_is_refused_naming_the_holder(tmp_path):
    out = tmp_path / "run"
    with run_lock(out):
        for resume in (False, True):
            with pytest.raises(RunLockedError, match=f"in use by pid {os.getpid()} on"):
                train(tiny_train_config(), out, resume=resume)
    assert not out.exists()  # the holder created the folder and wrote nothing: it is gone again

    # a real trainer holds it; a second one and a --resume are refused; killed, its lock is taken over
    release = tmp_path / "release"
    holder = subprocess.Popen([sys.executable, "-c", _DRIVER, f"hold_until:{release}", str(out), "new", "100000"],
                              cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        while not (out / "holding").exists():  # bounded by the holder's own progress, not a clock
            assert holder.poll() is None, holder.communicate()[1][-2000:]
            time.sleep(0.1)
        for resume in ("new", "resume"):
            second = _drive("none", out, resume=resume == "resume")
            assert second.returncode == 1 and f"in use by pid {holder.pid}" in second.stderr, second.stderr[-2000:]
    finally:
        release.write_text("")
        holder.wait(timeout=HANG)
    assert holder.returncode == -signal.SIGKILL and (out / ".lock").exists()  # left by the dead holder
    (out / "holding").unlink()
    done = _drive("none", out, resume=True)
    assert done.returncode == 0, done.stderr[-2000:]
    assert json.loads((out / "state.json").read_text())["decisions"] == BUDGET


def test_a_lock_from_a_dead_process_is_taken_over_and_a_non_folder_refused(tmp_path):
    out = tmp_path / "run"
    out.mkdir()
    (out / ".lock").write_text(json.dumps({"pid": 999999999, "host": "gone"}))  # nobody holds it
    with run_lock(out):
        assert json.loads((out / ".lock").read_text())["pid"] == os.getpid()
    (tmp_path / "file").write_text("x")
    with pytest.raises(RunError, match="exists and is not a folder"):
        with run_lock(tmp_path / "file"):
            pass


def _small_filesystem(path: Path, size: str) -> bool:
    path.mkdir()
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", f"size={size}", "tmpfs", str(path)],
                          capture_output=True, text=True)
    return done.returncode == 0


def test_a_full_disk_ends_the_run_in_one_line_and_the_folder_resumes(tmp_path):
    disk = tmp_path / "disk"
    if not _small_filesystem(disk, "16m"):
        pytest.skip("cannot mount a small tmpfs here (needs root or CAP_SYS_ADMIN)")
    try:
        out = disk / "run"
        train(tiny_train_config(timesteps=160, checkpoint_every=2), out)
        # fill the disk: the next checkpoint (~1 MB) cannot be written
        filler = disk / "filler"
        with filler.open("wb", buffering=0) as fh:
            try:
                while True:
                    fh.write(b"\0" * 4096)
            except OSError:
                pass
        with pytest.raises(RunError, match=r"failed \(No space left on device\).*make room, then continue it "
                                           r"with --resume"):
            train(tiny_train_config(timesteps=BUDGET, checkpoint_every=2), out, resume=True)
        assert not list(out.rglob("*.partial")) and not (out / ".lock").exists()
        filler.unlink()
        train(tiny_train_config(timesteps=BUDGET, checkpoint_every=2), out, resume=True)
        _finished_cleanly(out)
    finally:
        subprocess.run(["umount", str(disk)], capture_output=True)


def test_a_refused_write_is_one_line_on_any_machine(tmp_path, monkeypatch):
    """Where no small filesystem can be made: the checkpoint writer refused as a full disk would."""
    import errno

    import training.runs.checkpoint as checkpoint

    out = tmp_path / "run"
    train(tiny_train_config(timesteps=160, checkpoint_every=2), out)

    def full(path, data):
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(path))

    monkeypatch.setattr(checkpoint, "write_bytes_atomic", full)
    with pytest.raises(RunError, match=r"writing .*model_320.safetensors failed \(No space left on device\)"):
        train(tiny_train_config(timesteps=BUDGET, checkpoint_every=2), out, resume=True)
    monkeypatch.undo()
    train(tiny_train_config(timesteps=BUDGET, checkpoint_every=2), out, resume=True)
    _finished_cleanly(out)
    assert np.all(np.diff(_logged_decisions(out)) > 0)


def test_a_corrupt_state_file_does_not_stop_a_resume(tmp_path):
    """The run's state travels in each checkpoint; a broken state.json is not needed."""
    out = tmp_path / "run"
    train(tiny_train_config(timesteps=160, checkpoint_every=2), out)
    (out / "state.json").write_text('{"decisions": "many"')
    train(tiny_train_config(timesteps=BUDGET, checkpoint_every=2), out, resume=True)
    _finished_cleanly(out)
