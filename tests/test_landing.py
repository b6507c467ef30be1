"""Landing a running sweep trial by trial (``reproduce --run``): summary copies and learning curves
drawn once per finished trial, kept across machines, redrawn when a trial was continued."""

import csv
import dataclasses
import json
import time

import pytest

from training.evaluation.checkpoint_curve import CurveError
from training.results.landing import TrialLander
from training.sweeps import curves
from training.sweeps import kept as kept_module
from training.sweeps.spec import SweepSpec
from training.sweeps.summary import summary_row, write_summary

EPISODES, SEED = 3, 1_000_000_000


def _sweep(tmp_path, done=("num_cars=1",), checkpoints=(100, 200)):
    """A sweep folder of two trials (1 and 2 cars, seed 0): ``done`` ones finished; each has a run
    folder with checkpoints at ``checkpoints`` decisions (names only: drawing is faked)."""
    out = tmp_path / "sweep"
    spec = SweepSpec("lights", grid={"num_cars": ["1", "2"]}, seeds=1)
    out.mkdir(parents=True)
    (out / "sweep.json").write_text(json.dumps(dataclasses.asdict(spec)))
    rows = []
    for trial in spec.trials():
        run = out / "tune" / trial["name"] / "run" / "checkpoints"
        run.mkdir(parents=True)
        for d in checkpoints:
            (run / f"model_{d}.safetensors").write_bytes(b"")
        finished = f"num_cars={trial['point']['num_cars']}" in done
        rows.append(summary_row(trial, "done" if finished else "pending",
                                {"report/success_rate": 0.5} if finished else {}))
    write_summary(out, spec, rows)
    return out, spec


class _Calls(list):
    """Drawn runs, with ``kept``: the trials whose weights were kept."""

    kept: list


@pytest.fixture
def drawn(monkeypatch):
    """Fake curve drawing: one row per kept checkpoint; records which runs were drawn."""
    calls = _Calls()

    def fake_run_curve(run, episodes, seed, log=lambda line: None, skip=()):
        calls.append(run.parent.name)
        return [{"decisions": c["decisions"], "agent_steps": float("nan"), "episodes": episodes,
                 "first_seed": seed, "success_rate": 0.25} for c in curves.kept_checkpoints(run)
                if c["decisions"] not in skip]

    monkeypatch.setattr(curves, "run_curve", fake_run_curve)

    def fake_keep(run, dest):  # the run folders here hold no weights (tests/test_kept_weights.py keeps real ones)
        kept.append(dest.name)
        (dest / "config.json").parent.mkdir(parents=True, exist_ok=True)
        (dest / "config.json").write_text("{}")
        return dest

    kept: list = []
    monkeypatch.setattr(kept_module, "keep_final_weights", fake_keep)
    calls.kept = kept
    return calls


def _curve_rows(path):
    with open(path, newline="") as f:
        return list(csv.DictReader(f))


def test_each_finished_trial_lands_once_with_its_summary(tmp_path, drawn):
    out, _ = _sweep(tmp_path)
    folder = tmp_path / "assets"
    lander = TrialLander(out, folder, "tiny", EPISODES, SEED, log=lambda line: None)
    assert lander.land() == ["lights_num_cars=1_seed=0"]
    # the summary is copied less the trial not started yet (no empty row to commit mid-sweep)
    sweep = json.loads((out / "summary.json").read_text())
    landed = json.loads((folder / "tiny.json").read_text())
    assert [r["status"] for r in sweep["trials"]] == ["done", "pending"]
    assert landed == {"sweep": sweep["sweep"], "trials": sweep["trials"][:1]}
    sweep_csv = (out / "summary.csv").read_text().splitlines(keepends=True)
    assert (folder / "tiny.csv").read_text() == "".join(sweep_csv[:2]) and len(sweep_csv) == 3
    rows = _curve_rows(folder / "curves" / "tiny.csv")
    assert [(r["trial"], r["seed"], r["num_cars"], r["decisions"], r["episodes"]) for r in rows] == [
        ("lights_num_cars=1_seed=0", "0", "1", "100", "3"), ("lights_num_cars=1_seed=0", "0", "1", "200", "3")]
    assert lander.land() == [] and drawn == ["lights_num_cars=1_seed=0"]
    assert drawn.kept == ["lights_num_cars=1_seed=0"]  # its final weights kept, once
    assert (folder / "weights" / "tiny" / "lights_num_cars=1_seed=0" / "config.json").exists()

    # the second trial finishes: only it is drawn, the first one's rows stay
    out2, spec = _sweep(tmp_path / "b", done=("num_cars=1", "num_cars=2"))
    (out / "summary.json").write_text((out2 / "summary.json").read_text())
    assert lander.land() == ["lights_num_cars=2_seed=0"]
    assert {r["trial"] for r in _curve_rows(folder / "curves" / "tiny.csv")} == {
        "lights_num_cars=1_seed=0", "lights_num_cars=2_seed=0"}
    assert json.loads((folder / "tiny.json").read_text())["trials"][1]["status"] == "done"
    assert (folder / "tiny.csv").read_text() == (out2 / "summary.csv").read_text()

    # the same command again on this machine (a new lander): nothing is drawn twice
    assert TrialLander(out, folder, "tiny", EPISODES, SEED, log=lambda line: None).land() == []
    # ... unless on other episodes, or the trial was continued to more checkpoints (--extend)
    assert TrialLander(out, folder, "tiny", EPISODES + 1, SEED, log=lambda line: None).land() == [
        "lights_num_cars=1_seed=0", "lights_num_cars=2_seed=0"]
    (out / "tune" / "lights_num_cars=1_seed=0" / "run" / "checkpoints" / "model_300.safetensors").write_bytes(b"")
    assert TrialLander(out, folder, "tiny", EPISODES + 1, SEED, log=lambda line: None).land() == [
        "lights_num_cars=1_seed=0"]
    rows = [r for r in _curve_rows(folder / "curves" / "tiny.csv") if r["trial"] == "lights_num_cars=1_seed=0"]
    assert [r["decisions"] for r in rows] == ["100", "200", "300"]

    # a trial stopped part-way (the sweep was interrupted) is left out like a pending one: the next
    # run of the sweep continues it; a failed trial is kept (the page lists it as not finished)
    stopped = json.loads((out / "summary.json").read_text())
    stopped["trials"][1]["status"] = "stopped"
    (out / "summary.json").write_text(json.dumps(stopped))
    assert lander.copy_summary()
    expected = {"sweep": stopped["sweep"], "trials": stopped["trials"][:1]}
    assert json.loads((folder / "tiny.json").read_text()) == expected
    stopped["trials"][1]["status"] = "error"
    (out / "summary.json").write_text(json.dumps(stopped))
    assert lander.copy_summary()
    assert json.loads((folder / "tiny.json").read_text()) == stopped


def test_trials_from_another_machine_keep_their_rows_and_an_empty_sweep_lands_nothing(tmp_path, drawn):
    out, _ = _sweep(tmp_path)
    folder = tmp_path / "assets"
    (folder / "curves").mkdir(parents=True)
    other = {"trial": "lights_num_cars=4_seed=0", "seed": "0", "num_cars": "4", "decisions": "100",
             "agent_steps": "", "episodes": "3", "first_seed": str(SEED), "success_rate": "0.9"}
    with open(folder / "curves" / "tiny.csv", "w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=list(other))
        writer.writeheader()
        writer.writerow(other)
    TrialLander(out, folder, "tiny", EPISODES, SEED, log=lambda line: None).land()
    trials = [r["trial"] for r in _curve_rows(folder / "curves" / "tiny.csv")]
    assert trials[0] == "lights_num_cars=4_seed=0" and trials.count("lights_num_cars=1_seed=0") == 2

    # a sweep that has not written a summary yet: nothing copied, nothing drawn
    empty = tmp_path / "empty"
    empty.mkdir()
    lander = TrialLander(empty, tmp_path / "assets2", "tiny", EPISODES, SEED, log=lambda line: None)
    assert lander.land() == [] and not (tmp_path / "assets2").exists()


def test_background_passes_land_trials_while_the_sweep_runs_and_log_failures(tmp_path, drawn, monkeypatch):
    out, _ = _sweep(tmp_path)
    folder = tmp_path / "assets"
    lines = []
    lander = TrialLander(out, folder, "tiny", EPISODES, SEED, log=lines.append)
    lander.start(every_s=0.02)
    deadline = time.monotonic() + 30
    while not drawn and time.monotonic() < deadline:
        time.sleep(0.02)
    lander.stop()
    assert drawn == ["lights_num_cars=1_seed=0"] and (folder / "curves" / "tiny.csv").exists()
    assert lander._thread is None

    # a curve that cannot be drawn: logged by the background pass (the sweep goes on), raised by
    # the final pass in the caller's thread
    def broken(run, episodes, seed, log=lambda line: None, skip=()):
        raise CurveError(f"no checkpoints in {run}")

    monkeypatch.setattr(curves, "run_curve", broken)
    out2, _ = _sweep(tmp_path / "b", done=("num_cars=1", "num_cars=2"))
    lander = TrialLander(out2, tmp_path / "assets-b", "tiny", EPISODES, SEED, log=lines.append)
    lander.start(every_s=0.02)
    deadline = time.monotonic() + 30
    while not any("landing tiny" in line for line in lines) and time.monotonic() < deadline:
        time.sleep(0.02)
    lander.stop()
    assert any("landing tiny: no checkpoints in" in line and "tried again at the end" in line for line in lines)
    with pytest.raises(CurveError):
        lander.land()


def test_a_finished_trial_is_read_from_its_last_checkpoint_not_the_synced_trial_folder(tmp_path):
    """A finished trial's curve is drawn from its last checkpoint folder, which the summary names;
    otherwise (not finished, or the summary names a folder outside this trial) from the newest
    checkpoint the trial reported into its own folder, and with none, from ``run/`` (the live copy
    older sweep folders hold, as this one does)."""
    out, spec = _sweep(tmp_path)
    name = "lights_num_cars=1_seed=0"
    final = out / "tune" / name / "checkpoint_000002"
    final.mkdir()
    (final / "state.json").write_text("{}")
    summary = json.loads((out / "summary.json").read_text())
    summary["trials"][0]["run"] = str(final)
    summary["trials"][1]["run"] = str(final)  # not finished: its own run/ is still read
    (out / "summary.json").write_text(json.dumps(summary))
    runs = {t["trial"]: t["run"] for t in curves.sweep_trials(out)}
    assert runs == {name: final, "lights_num_cars=2_seed=0": out / "tune" / "lights_num_cars=2_seed=0" / "run"}
    summary["trials"][0]["run"] = str(tmp_path / "elsewhere" / "checkpoint_000002")  # e.g. a reused row
    (out / "summary.json").write_text(json.dumps(summary))
    assert curves.sweep_trials(out)[0]["run"] == final  # its own newest reported checkpoint


def _stop_part_way(out, name, checkpoints=(100, 200), number=1):
    """Mark trial ``name`` of the sweep in ``out`` stopped part-way, its last checkpoint folder a
    run folder (seed 0) with kept checkpoints, logs and TensorBoard files; returns that folder."""
    final = out / "tune" / name / f"checkpoint_{number:06d}"
    (final / "checkpoints").mkdir(parents=True)
    (final / "tb").mkdir()
    for d in checkpoints:
        (final / "checkpoints" / f"model_{d}.safetensors").write_bytes(b"kept")
    (final / "config.json").write_text(json.dumps({"seed": 0, "timesteps": 1000}))
    (final / "state.json").write_text(json.dumps({"decisions": checkpoints[-1]}))
    (final / "model.safetensors").write_bytes(b"latest")
    (final / "progress.csv").write_text("time/decisions\n100\n200\n")
    (final / "events.out.tfevents.1.vm").write_bytes(b"tb")
    summary = json.loads((out / "summary.json").read_text())
    for r in summary["trials"]:
        if r["trial"] == name:
            r["status"], r["run"] = "stopped", str(final)
    (out / "summary.json").write_text(json.dumps(summary))
    return final


def test_a_trial_stopped_part_way_is_carried_with_its_curve_so_far_and_removed_once_it_lands(tmp_path, drawn):
    from training.sweeps.carry import carried_runs

    out, spec = _sweep(tmp_path)
    folder = tmp_path / "assets"
    name = "lights_num_cars=2_seed=0"
    _stop_part_way(out, name)
    lander = TrialLander(out, folder, "tiny", EPISODES, SEED, log=lambda line: None)
    lander.land()
    assert lander.carry() == [name]
    carried = folder / "carried" / "tiny" / name
    # the resumable part travels; kept checkpoints, TensorBoard logs stay behind
    assert sorted(p.name for p in carried.iterdir()) == ["config.json", "model.safetensors", "progress.csv",
                                                        "state.json"]
    assert (carried / "model.safetensors").read_bytes() == b"latest"
    assert carried_runs(lander.carried_folder, spec) == {name: carried}
    # its curve so far is drawn (from its last checkpoint folder), but the stopped trial has no
    # summary row to commit
    rows = [r for r in _curve_rows(lander.curves_path) if r["trial"] == name]
    assert [r["decisions"] for r in rows] == ["100", "200"]
    assert [r["trial"] for r in json.loads((folder / "tiny.json").read_text())["trials"]] == [
        "lights_num_cars=1_seed=0"]

    # carried again after more training: its newer run replaces the old carry, only the new
    # checkpoint is drawn
    drawn.clear()
    _stop_part_way(out, name, checkpoints=(100, 200, 300), number=2)
    assert TrialLander(out, folder, "tiny", EPISODES, SEED, log=lambda line: None).carry() == [name]
    assert json.loads((carried / "state.json").read_text()) == {"decisions": 300}
    assert not list(carried.parent.glob("*.partial"))
    assert [r["decisions"] for r in _curve_rows(lander.curves_path) if r["trial"] == name] == ["100", "200", "300"]

    # continued on another machine from the carried run: the new run has only the checkpoints after
    # the carry; its curve keeps the rows drawn before, and once the trial lands the carry goes
    later = tmp_path / "later"
    out3, _ = _sweep(later, done=("num_cars=1", "num_cars=2"), checkpoints=(400, 500))
    assert TrialLander(out3, folder, "tiny", EPISODES, SEED, log=lambda line: None).land() == [
        "lights_num_cars=1_seed=0", name]
    rows = [r for r in _curve_rows(lander.curves_path) if r["trial"] == name]
    assert [r["decisions"] for r in rows] == ["100", "200", "300", "400", "500"]
    assert not carried.exists()


def test_a_carry_left_behind_by_a_trial_that_landed_elsewhere_is_removed(tmp_path, drawn):
    """A trial continued from its carry and finished on another machine, whose summary was
    committed with the carry still beside it: here the trial is done with no run folder (taken
    from the committed summary), and its stale carry goes, while a running trial's carry stays."""
    import shutil

    from training.sweeps.carry import carry_run

    out, _ = _sweep(tmp_path, done=("num_cars=1",))
    folder = tmp_path / "assets"
    final = _stop_part_way(out, "lights_num_cars=2_seed=0")
    lander = TrialLander(out, folder, "tiny", EPISODES, SEED, log=lambda line: None)
    for name in ("lights_num_cars=1_seed=0", "lights_num_cars=2_seed=0"):
        carry_run(final, lander.carried_folder / name)
    shutil.rmtree(out / "tune" / "lights_num_cars=1_seed=0")  # done, taken from a committed summary
    assert lander.land() == []
    assert not (lander.carried_folder / "lights_num_cars=1_seed=0").exists()
    assert (lander.carried_folder / "lights_num_cars=2_seed=0").is_dir()  # not done: still carried


def test_a_stopped_trial_without_a_checkpoint_is_not_carried_and_a_bad_carry_is_refused(tmp_path, drawn):
    from training.sweeps.carry import carried_runs, carry_run
    from training.sweeps.spec import SweepError

    out, spec = _sweep(tmp_path)
    summary = json.loads((out / "summary.json").read_text())
    summary["trials"][1]["status"] = "stopped"  # stopped before its first checkpoint
    (out / "summary.json").write_text(json.dumps(summary))
    lander = TrialLander(out, tmp_path / "assets", "tiny", EPISODES, SEED, log=lambda line: None)
    assert lander.carry() == [] and not lander.carried_folder.exists()
    assert carried_runs(lander.carried_folder, spec) == {}  # none: nothing to continue
    with pytest.raises(SweepError, match="not a run folder to carry"):
        carry_run(out / "tune" / "lights_num_cars=2_seed=0" / "run", tmp_path / "c" / "x")

    final = _stop_part_way(out, "lights_num_cars=2_seed=0")
    (final / ".lock").write_text("4242 vm\n")  # a lock left by the process that trained there
    folder = tmp_path / "carried"
    carry_run(final, folder / "lights_num_cars=2_seed=0")
    assert list(carried_runs(folder, spec)) == ["lights_num_cars=2_seed=0"]
    assert not (folder / "lights_num_cars=2_seed=0" / ".lock").exists()  # that machine's, not carried
    carry_run(final, folder / "lights_num_cars=8_seed=0")
    with pytest.raises(SweepError, match="lights_num_cars=8_seed=0 is not a trial of this sweep"):
        carried_runs(folder, spec)
    (folder / "lights_num_cars=8_seed=0").rename(folder / "lights_num_cars=2_seed=1")
    with pytest.raises(SweepError, match="trained with seed 0, the trial's seed is 1"):
        carried_runs(folder, dataclasses.replace(spec, seeds=2))
    (folder / "lights_num_cars=2_seed=1").rename(folder / "lights_num_cars=1_seed=0")
    (folder / "lights_num_cars=1_seed=0" / "state.json").write_text("{not json")
    with pytest.raises(SweepError, match="lights_num_cars=1_seed=0: not a run folder"):
        carried_runs(folder, spec)
