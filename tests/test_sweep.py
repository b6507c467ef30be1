"""``box2d-driving sweep``: grid validation, and a real Ray Tune sweep on this machine that is
interrupted, continued, isolates a failing trial and summarises every trial on report seeds."""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from training.common.seeds import REPORT
from training.sweeps.sweep import prepare_out
from training.sweeps.spec import SweepError, SweepSpec, check_spec, parse_pairs
from tests.helpers import HANG

ROOT = Path(__file__).resolve().parent.parent
SHIPPED = ROOT / "assets" / "policies" / "traffic_lights_4cars"


@pytest.mark.parametrize("spec,match", [
    (SweepSpec("flying"), "unknown behaviour"),
    (SweepSpec("lights", grid={"colour": ["red"]}), "'colour' is not an option"),
    (SweepSpec("lights", grid={"seed": ["1", "2"]}), "seeds come from --seeds"),
    (SweepSpec("lights", grid={"num_cars": ["4", "x"]}), "do not parse"),
    (SweepSpec("lights", grid={"n_envs": ["0"]}), "n_envs"),
    (SweepSpec("lights", grid={"remove_collided": ["maybe"]}), "true or false"),
    (SweepSpec("lanes", timesteps=1000), "rounds"),
    (SweepSpec("lights", grid={"num_cars": ["4"]}, fixed={"num_cars": "8"}), "both in --grid and --set"),
    (SweepSpec("lights", seeds=0), "--seeds"),
])
def test_bad_sweeps_are_refused_naming_the_culprit(spec, match):
    with pytest.raises(SweepError, match=match):
        check_spec(spec)


def test_grid_and_set_pairs_parse_or_name_the_bad_pair():
    assert parse_pairs(["lidar-noise=0,0.5", "num_cars=4"], "--grid", many=True) == {
        "lidar_noise": ["0", "0.5"], "num_cars": ["4"]}
    for bad in (["noise"], ["noise="], ["a=1,1"], ["a=1,,2"], ["a=1", "a=2"]):
        with pytest.raises(SweepError):
            parse_pairs(bad, "--grid", many=True)


def test_every_trial_runs_the_behaviours_own_options():
    spec = SweepSpec("lights", grid={"lidar_noise": ["0", "0.5"], "num_cars": ["1", "4"]}, seeds=2,
                     fixed={"remove_collided": "true"}, timesteps=1000)
    trials = spec.trials()
    assert len(trials) == 8 and len({t["name"] for t in trials}) == 8
    first = trials[0]
    assert first["argv"] == ["--seed", "0", "--remove-collided", "--lidar-noise", "0", "--num-cars", "1",
                             "--timesteps", "1000"]
    check_spec(spec)


def test_a_different_sweep_or_a_foreign_folder_is_refused(tmp_path):
    spec = SweepSpec("lights", grid={"lidar_noise": ["0"]})
    assert prepare_out(tmp_path / "s", spec) is False
    assert prepare_out(tmp_path / "s", spec) is False  # same sweep, nothing run yet
    with pytest.raises(SweepError, match="different sweep"):
        prepare_out(tmp_path / "s", SweepSpec("lights", grid={"lidar_noise": ["0.5"]}))
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "notes.txt").write_text("mine")
    with pytest.raises(SweepError, match="holds no sweep"):
        prepare_out(tmp_path / "other", spec)
    assert (tmp_path / "other" / "notes.txt").read_text() == "mine"


@pytest.mark.parametrize("resources,match", [
    ({"cpus_per_trial": 0}, "--cpus-per-trial must be > 0"),
    ({"gpus_per_trial": -1}, "--gpus-per-trial >= 0"),
    ({"max_concurrent": 0}, "--max-concurrent must be at least 1, got 0"),  # Ray Tune would read 0 as no limit
])
def test_bad_resources_are_refused_before_anything_is_written(tmp_path, resources, match):
    from training.sweeps.sweep import run_sweep

    with pytest.raises(SweepError, match=match):
        run_sweep(SweepSpec("lights", timesteps=100), tmp_path / "s", **resources)
    assert not (tmp_path / "s").exists()


def _sweep(out: Path, timesteps: int) -> list[str]:
    return [sys.executable, "-m", "box2d_driving", "sweep", "lights",
            "--grid", f"init_from={SHIPPED},{out.parent / 'no_such_run'}", "--seeds", "1",
            "--timesteps", str(timesteps), "--episodes", "3",
            "--set", "n_envs=2", "batch_decisions=80", "epochs=1", "--out", str(out)]


# decisions per trial: enough that a fast machine is still training when the test interrupts it
BUDGET = 20000


@pytest.mark.e2e
def test_sweep_is_interrupted_continued_isolates_a_failing_trial_and_reports_on_report_seeds(tmp_path):
    out = tmp_path / "sweep"
    env = {**os.environ, "SDL_VIDEODRIVER": "dummy", "RAY_DEDUP_LOGS": "0"}
    good = "lights_init_from=" + str(SHIPPED).replace("/", "-") + "_seed=0"
    proc = subprocess.Popen(_sweep(out, BUDGET) + ["--max-concurrent", "1"], cwd=ROOT, env=env, stdout=subprocess.PIPE,
                            stderr=subprocess.STDOUT, text=True, start_new_session=True)
    deadline = time.time() + HANG
    result = out / "tune" / good / "result.json"  # written once the driver has taken a report in
    while time.time() < deadline and not (result.exists() and result.read_text().strip()):
        time.sleep(0.2)  # wait for the good trial's first checkpoint (after 10 updates)
    assert list((out / "tune" / good).glob("checkpoint_*")), "no checkpoint before the hang guard"
    time.sleep(2)  # the experiment's state records it (Ray snapshots it right after a checkpoint)
    os.killpg(proc.pid, signal.SIGINT)  # Ctrl-C, as a user stops it
    log = proc.communicate(timeout=HANG)[0]
    first = min((json.loads(p.read_text()) for p in (out / "tune" / good).glob("checkpoint_*/state.json")),
                key=lambda state: state["decisions"])
    assert first["decisions"] < BUDGET, log[-3000:]
    # stopped with one trial running and one not started: both in the summary, no traceback
    assert proc.returncode == 1 and "Traceback" not in log, log[-3000:]
    # the trial trained in its own working directory: only its reported checkpoints are copied here
    assert not (out / "tune" / good / "run").exists()
    stopped = {r["trial"]: r["status"] for r in csv.DictReader((out / "summary.csv").open())}
    assert stopped[good] == "stopped" and sorted(stopped.values()) == ["pending", "stopped"], stopped

    # the machine goes away: the stopped trial, carried to a new folder, continues from where it was
    from training.sweeps.carry import carry_run

    last = Path(next(r for r in csv.DictReader((out / "summary.csv").open()) if r["trial"] == good)["run"])
    at = json.loads((last / "state.json").read_text())["decisions"]
    carry_run(last, tmp_path / "carried" / good)
    assert not (tmp_path / "carried" / good / "checkpoints").exists()
    moved = tmp_path / "carried-to"
    cont = subprocess.run(_sweep(moved, BUDGET) + ["--carried", str(tmp_path / "carried")], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=HANG)
    assert "1 of 2 trials done" in cont.stdout, cont.stdout[-3000:] + cont.stderr[-3000:]
    row = next(r for r in csv.DictReader((moved / "summary.csv").open()) if r["trial"] == good)
    assert row["status"] == "done" and int(row["decisions"]) == BUDGET
    assert [p.name for p in Path(row["run"]).glob("config.resumed_*.json")] == [f"config.resumed_{at:012d}.json"]
    # a carried folder that is not this sweep's is refused before anything runs
    (tmp_path / "carried" / "lights_seed=7").mkdir()
    bad_carry = subprocess.run(_sweep(tmp_path / "never", BUDGET) + ["--carried", str(tmp_path / "carried")],
                               cwd=ROOT, env=env, capture_output=True, text=True, timeout=HANG)
    assert bad_carry.returncode == 2 and "lights_seed=7 is not a trial of this sweep" in bad_carry.stderr
    assert not (tmp_path / "never").exists()

    run = subprocess.run(_sweep(out, BUDGET), cwd=ROOT, env=env, capture_output=True, text=True, timeout=HANG)
    assert run.returncode == 1, run.stdout[-3000:] + run.stderr[-3000:]  # one trial failed
    assert "1 of 2 trials done" in run.stdout
    # Ray Tune continues with the concurrency the sweep began with: said, not silently dropped
    assert "continues with the --max-concurrent it started with: 1 (asked: (none))" in run.stderr
    rows = {r["trial"]: r for r in csv.DictReader((out / "summary.csv").open())}
    assert rows[good]["status"] == "done" and int(rows[good]["decisions"]) == BUDGET
    bad = next(r for name, r in rows.items() if name != good)
    assert bad["status"] == "error" and "no_such_run" in bad["error"]
    # the good trial continued from its checkpoint rather than starting again
    final = Path(rows[good]["run"])
    assert list(final.glob("config.resumed_*.json")), sorted(p.name for p in final.iterdir())
    metrics = json.loads((final / "eval" / "metrics.json").read_text())
    assert metrics["seed_set"] == "report" and metrics["seed"] in REPORT and metrics["episodes"] == 3
    assert float(rows[good]["success_rate"]) == metrics["success_rate"]
    summary = json.loads((out / "summary.json").read_text())
    assert summary["sweep"]["grid"]["init_from"][0] == str(SHIPPED)
    assert int(rows[good]["report_first_seed"]) in REPORT

    # a finished sweep, run again: nothing is retrained or re-evaluated
    stamp = (final / "eval" / "metrics.json").stat().st_mtime_ns
    again = subprocess.run(_sweep(out, BUDGET), cwd=ROOT, env=env, capture_output=True, text=True, timeout=HANG)
    assert "1 of 2 trials done" in again.stdout, again.stderr[-3000:]
    rows2 = {r["trial"]: r for r in csv.DictReader((out / "summary.csv").open())}
    assert Path(rows2[good]["run"]) == final and (final / "eval" / "metrics.json").stat().st_mtime_ns == stamp

    # on another machine: a new folder that reuses the committed summary trains only what is missing
    moved = tmp_path / "elsewhere"
    reuse = subprocess.run(_sweep(moved, BUDGET) + ["--reuse", str(out / "summary.json")], cwd=ROOT, env=env,
                           capture_output=True, text=True, timeout=HANG)
    assert "1 of 2 trials done" in reuse.stdout, reuse.stderr[-3000:]
    rows3 = {r["trial"]: r for r in csv.DictReader((moved / "summary.csv").open())}
    assert rows3[good] == rows2[good]  # taken as it was: same metrics, same run folder named
    assert not list((moved / "tune" / good).glob("checkpoint_*"))  # nothing trained for it

    # a larger budget: the finished trial continues from its last checkpoint instead of starting over
    longer = tmp_path / "longer"
    more = subprocess.run(_sweep(longer, BUDGET + 2000) + ["--extend", str(out)], cwd=ROOT, env=env,
                          capture_output=True, text=True, timeout=HANG)
    assert "1 of 2 trials done" in more.stdout, more.stdout[-3000:] + more.stderr[-3000:]
    assert f"--extend: 1 finished trial of {out} continue" in more.stderr
    rows4 = {r["trial"]: r for r in csv.DictReader((longer / "summary.csv").open())}
    run4 = Path(rows4[good]["run"])
    assert rows4[good]["status"] == "done" and int(rows4[good]["decisions"]) == BUDGET + 2000
    assert (run4 / f"config.resumed_{BUDGET:012d}.json").exists(), sorted(p.name for p in run4.iterdir())
    # the first leg's checkpoints come along (a learning curve covers the whole run), its evaluation does not
    kept = {p.name for p in (run4 / "checkpoints").iterdir()}
    assert {p.name for p in (final / "checkpoints").iterdir()} <= kept
    assert json.loads((run4 / "eval" / "metrics.json").read_text())["episodes"] == 3
    assert (final / "eval" / "metrics.json").stat().st_mtime_ns == stamp  # the old sweep is untouched
    assert rows4[next(n for n in rows4 if n != good)]["status"] == "error"


@pytest.mark.e2e
def test_a_time_limit_stops_the_sweep_as_ctrl_c_would(tmp_path):
    """``--time-limit``: the sweep stops itself once the limit has passed (here before a trial
    can finish: each would train 100 times the interrupted test's budget), through Ray Tune's own
    stop, so nothing is marked done, the summary holds every trial and the command says how to go
    on; bad limits are refused before anything is written."""
    out = tmp_path / "sweep"
    env = {**os.environ, "SDL_VIDEODRIVER": "dummy", "RAY_DEDUP_LOGS": "0"}
    run = subprocess.run(_sweep(out, 100 * BUDGET) + ["--max-concurrent", "1", "--time-limit", "0.25"], cwd=ROOT,
                         env=env, capture_output=True, text=True, timeout=HANG)
    log = run.stdout[-3000:] + run.stderr[-3000:]
    assert run.returncode == 1 and "--time-limit reached" in run.stderr and "Traceback" not in log, log
    statuses = {r["trial"]: r["status"] for r in csv.DictReader((out / "summary.csv").open())}
    assert len(statuses) == 2 and "done" not in statuses.values(), statuses
    assert "run the same command again to continue" in run.stdout
    for bad in ("0", "-3", "nan"):
        refused = subprocess.run(_sweep(tmp_path / "never", BUDGET) + ["--time-limit", bad], cwd=ROOT, env=env,
                                 capture_output=True, text=True, timeout=HANG)
        assert refused.returncode == 2 and "--time-limit: " in refused.stderr and "minutes" in refused.stderr
    assert not (tmp_path / "never").exists()


def test_a_continued_sweep_says_it_keeps_the_concurrency_it_started_with(tmp_path):
    from training.sweeps.sweep import CONCURRENCY_FILE, kept_concurrency

    assert kept_concurrency(tmp_path, 3) == ""  # begun before the limit was recorded
    (tmp_path / CONCURRENCY_FILE).write_text(json.dumps({"max_concurrent": 2}))
    assert kept_concurrency(tmp_path, 2) == ""
    note = kept_concurrency(tmp_path, 3)
    assert "--max-concurrent it started with: 2 (asked: 3)" in note
    assert f"--reuse {tmp_path / 'summary.json'}" in note
    assert "(asked: (none))" in kept_concurrency(tmp_path, None)


def test_reuse_refuses_another_sweeps_summary(tmp_path):
    from training.sweeps.summary import reusable_rows, write_summary

    spec = SweepSpec("lights", grid={"lidar_noise": ["0"]})
    write_summary(tmp_path, spec, [{"trial": "t", "behaviour": "lights", "seed": 0, "status": "done"}])
    assert set(reusable_rows(tmp_path / "summary.json", spec)) == {"t"}
    # more seeds of the same settings: the finished seed is kept, the new ones are trained
    five_seeds = SweepSpec("lights", grid={"lidar_noise": ["0"]}, seeds=5)
    assert set(reusable_rows(tmp_path / "summary.json", five_seeds)) == {"t"}
    assert reusable_rows(tmp_path / "summary.json", SweepSpec("lights", grid={"lidar_noise": ["0"]}, seeds=0)) == {}
    with pytest.raises(SweepError, match="another sweep"):
        reusable_rows(tmp_path / "summary.json", SweepSpec("lights", grid={"lidar_noise": ["0.5"]}))
    (tmp_path / "bad.json").write_text("[1, 2]")
    with pytest.raises(SweepError, match="not a sweep summary"):
        reusable_rows(tmp_path / "bad.json", spec)


def test_a_stop_keeps_the_rows_of_finished_trials_it_had_not_reached(tmp_path):
    """A sweep continuing a committed summary (``--reuse``, as ``reproduce --run`` does) and stopped
    before it reached some finished trials writes their earlier rows as they were; a trial never
    run is pending. (Seen: a stop after seed 2 dropped the finished seeds 4-5 from the summary.)"""
    from training.sweeps.summary import reusable_rows, unreached_row, write_summary

    spec = SweepSpec("lights", grid={"lidar_noise": ["0.25", "0.5"]}, seeds=2)
    done = {"trial": "lights_lidar_noise=0.25_seed=1", "behaviour": "lights", "seed": 1, "status": "done",
            "lidar_noise": "0.25", "success_rate": 0.75, "run": "/elsewhere/checkpoint_000008"}
    write_summary(tmp_path, spec, [done])
    reused = reusable_rows(tmp_path / "summary.json", spec)
    trials = {t["name"]: t for t in spec.trials()}
    for name, trial in trials.items():
        trial["reuse"] = reused.get(name)
    rows = {name: unreached_row(trial) for name, trial in trials.items()}
    assert rows[done["trial"]] == done  # as it was: no extra keys, nothing re-measured
    others = [r for name, r in rows.items() if name != done["trial"]]
    assert len(others) == 3 and all(r["status"] == "pending" for r in others)


def test_an_extension_needs_the_same_sweep_at_a_larger_budget(tmp_path):
    import dataclasses

    from training.sweeps.spec import extension_differences
    from training.sweeps.summary import extendable_runs
    from training.sweeps.sweep import extended_sweep

    old = SweepSpec("lights", grid={"lidar_noise": ["0", "0.5"]}, timesteps=1000, fixed={"num_cars": "4"})
    saved = json.loads(json.dumps(dataclasses.asdict(old)))
    assert extension_differences(saved, dataclasses.replace(old, timesteps=5000)) == []
    assert extension_differences(saved, dataclasses.replace(old, timesteps=5000, seeds=5)) == []  # more seeds too
    assert "budget" in extension_differences(saved, old)[0]
    assert "never less" in extension_differences(saved, dataclasses.replace(old, timesteps=500))[0]
    assert "never less" in extension_differences(saved, dataclasses.replace(old, timesteps=None))[0]
    assert "fixed num_cars" in extension_differences(saved, dataclasses.replace(old, timesteps=5000,
                                                                                fixed={"num_cars": "8"}))
    assert "grid" in extension_differences(saved, dataclasses.replace(old, timesteps=5000, grid={"lidar_noise": ["0"]}))
    # bilevel sweeps: their fixed rounds are the budget
    lanes = SweepSpec("lanes", fixed={"rounds": "48", "lidar_noise": "0.5"})
    lanes_saved = json.loads(json.dumps(dataclasses.asdict(lanes)))
    longer = dataclasses.replace(lanes, fixed={"rounds": "150", "lidar_noise": "0.5"})
    assert extension_differences(lanes_saved, longer) == []
    not_a_number = dataclasses.replace(lanes, fixed={"rounds": "x", "lidar_noise": "0.5"})
    assert "rounds" in extension_differences(lanes_saved, not_a_number)[0]

    # the old folder's finished trials with their run on this machine
    old_out = tmp_path / "old"
    (old_out / "run0").mkdir(parents=True)
    (old_out / "run0" / "state.json").write_text("{}")
    (old_out / "sweep.json").write_text(json.dumps(saved))
    rows = [{"trial": "a", "status": "done", "run": str(old_out / "run0")},
            {"trial": "b", "status": "done", "run": str(old_out / "gone")},
            {"trial": "c", "status": "error", "run": str(old_out / "run0")}]
    (old_out / "summary.json").write_text(json.dumps({"sweep": saved, "trials": rows}))
    assert extendable_runs(old_out, dataclasses.replace(old, timesteps=5000)) == {"a": old_out / "run0"}
    with pytest.raises(SweepError, match=r"--extend .*cannot continue its trials \(the budget"):
        extendable_runs(old_out, old)
    with pytest.raises(SweepError, match="not a sweep folder"):
        extendable_runs(tmp_path, old)
    # a sweep folder keeps the folder it extends; a continued sweep may not switch to another
    new_out = tmp_path / "new"
    assert extended_sweep(new_out, old_out) == old_out.resolve() and extended_sweep(new_out, None) is None
    new_out.mkdir()
    (new_out / "extends.json").write_text(json.dumps({"extends": str(old_out.resolve())}))
    assert extended_sweep(new_out, None) == old_out.resolve()
    with pytest.raises(SweepError, match="extends"):
        extended_sweep(new_out, tmp_path / "elsewhere")
    (new_out / "extends.json").unlink()
    (new_out / "tune").mkdir()
    with pytest.raises(SweepError, match="began without --extend"):
        extended_sweep(new_out, old_out)


def test_without_ray_the_sweep_says_which_extra_to_install(monkeypatch, capsys, tmp_path):
    from training.sweeps.sweep import main

    monkeypatch.setitem(sys.modules, "ray", None)  # as if the [sweep] extra were not installed
    assert main(["lights", "--out", str(tmp_path / "s")]) == 2
    assert '".[train,sweep]"' in capsys.readouterr().err and not (tmp_path / "s").exists()


def test_a_continued_sweep_runs_the_summary_callback_of_the_code_installed_now(tmp_path):
    """Ray Tune pickles callbacks into the experiment's state; a class made inside a function is
    pickled with its code, so a sweep continued after an upgrade would run the old code. The
    summary callback is a module-level class: plain pickle stores it by name."""
    import pickle

    from training.sweeps.sweep import SummaryCallback

    cb = SummaryCallback(tmp_path, SweepSpec("lights"), {})
    data = pickle.dumps(cb)
    assert b"training.sweeps.sweep" in data and b"SummaryCallback" in data and b"on_trial_complete" not in data
    again = pickle.loads(data)
    assert type(again) is SummaryCallback and again.out == tmp_path


def test_curves_read_a_trials_reported_checkpoints_never_a_half_written_one(tmp_path):
    from training.sweeps.curves import run_folder

    trial = tmp_path / "tune" / "lights_seed=0"
    for name in ("checkpoint_000001", "checkpoint_000002", "checkpoint_000003"):
        (trial / name).mkdir(parents=True)
    for name in ("checkpoint_000001", "checkpoint_000002"):  # 3 is still being copied: no state.json yet
        (trial / name / "state.json").write_text("{}")
    assert run_folder(tmp_path, "lights_seed=0", None) == trial / "checkpoint_000002"  # running: the newest whole one
    done = {"status": "done", "run": str(trial / "checkpoint_000001")}
    assert run_folder(tmp_path, "lights_seed=0", done) == trial / "checkpoint_000001"  # finished: the summary's
    assert not run_folder(tmp_path, "lights_seed=1", None).exists()  # not started: nothing to read


_IGNORED_EXIT = """
import sys, weakref
from training.sweeps.worker_exit import exit_on_ignored_system_exit
if sys.argv[1] == "hook":
    exit_on_ignored_system_exit()
class Thing: pass
def stop(_):  # as Ray's SIGTERM handler does, landing in a callback Python cannot raise from
    raise SystemExit(3)
def other(_):
    raise ValueError("an ordinary ignored error")
thing, more = Thing(), Thing()
refs = [weakref.ref(more, other), weakref.ref(thing, stop)]
print("before", flush=True)
del more  # an ordinary ignored exception is still reported
del thing
print("still running")
"""


@pytest.mark.parametrize("hook", ["hook", "none"])
def test_a_stopped_trial_worker_exits_instead_of_printing_an_ignored_system_exit(hook):
    done = subprocess.run([sys.executable, "-c", _IGNORED_EXIT, hook], cwd=ROOT, capture_output=True, text=True,
                          timeout=HANG)
    assert "an ordinary ignored error" in done.stderr  # other ignored exceptions reported as before
    if hook == "hook":
        assert done.returncode == 3 and "still running" not in done.stdout and "SystemExit" not in done.stderr
    else:  # Python's own behaviour, which the sweep's test saw: a traceback, and the process carries on
        assert done.returncode == 0 and "still running" in done.stdout and "SystemExit" in done.stderr


def test_a_sweep_records_the_lidar_encoder_its_trials_build_and_reads_older_ones_as_ours(tmp_path):
    """Not given, the encoder is recorded (the default, a preset's, or a fine-tune's weights'), so
    a summary says what it ran with; a sweep from before it was recorded ran ours and is continued
    only by a sweep that asks for ours."""
    from training.sweeps.spec import saved_fixed, spec_differences

    cases = ((SweepSpec("lights", grid={"lidar_noise": ["0"]}), "original"),
             (SweepSpec("lights", fixed={"init_from": str(SHIPPED)}), "relu"),
             (SweepSpec("lights", fixed={"preset": "paper"}), "original"),
             (SweepSpec("lights", fixed={"lidar_encoder": "relu"}), "relu"))
    for spec, encoder in cases:
        check_spec(spec)
        assert spec.fixed["lidar_encoder"] == encoder
    grid = SweepSpec("lights", grid={"lidar_encoder": ["relu", "original"]})
    check_spec(grid)
    assert "lidar_encoder" not in grid.fixed
    old = {"behaviour": "lights", "grid": {"lidar_noise": ["0"]}, "seeds": 3, "fixed": {}, "timesteps": None,
           "minutes": None, "episodes": 200, "quick": False}  # a sweep.json of before
    assert saved_fixed(old) == {"lidar_encoder": "relu"}
    assert saved_fixed({**old, "fixed": {"preset": "paper"}}) == {
        "preset": "paper", "lidar_encoder": "original", "drive_on": "right", "arrived_heading_error": "zero",
        "goal_distance": "path", "light_view": "stop_line", "integration": "exact", "value_targets": "lambda_returns"}
    today = SweepSpec("lights", grid={"lidar_noise": ["0"]})
    check_spec(today)
    assert spec_differences(old, today) == ["fixed"]  # would mix encoders: refused
    ours = SweepSpec("lights", grid={"lidar_noise": ["0"]}, fixed={"lidar_encoder": "relu"})
    check_spec(ours)
    assert spec_differences(old, ours) == []


def test_a_paper_preset_sweep_records_the_world_its_trials_build_and_reads_older_ones_in_the_mirror_world():
    """The preset drives on the left since 2026-12-06: a sweep records that, one from before ran on
    the right (with an arrived car's heading error 0) and is continued only by a sweep that pins
    that world."""
    from training.sweeps.spec import saved_fixed, spec_differences

    now = SweepSpec("lights", fixed={"preset": "paper", "num_cars": "4"})
    check_spec(now)
    assert now.fixed["drive_on"] == "left" and now.fixed["arrived_heading_error"] == "minus_heading"
    assert now.fixed["goal_distance"] == "straight" and now.fixed["light_view"] == "axis_point"
    assert now.fixed["integration"] == "euler" and now.fixed["value_targets"] == "rewards_to_go"
    default = SweepSpec("lights", fixed={"num_cars": "4"})
    check_spec(default)
    assert "drive_on" not in default.fixed  # our default world: nothing to record
    assert "value_targets" not in default.fixed  # nor our update
    old = {"behaviour": "lights", "grid": {}, "seeds": 3, "fixed": {"preset": "paper", "num_cars": "4"},
           "timesteps": None, "minutes": None, "episodes": 200, "quick": False}  # a preset sweep of before
    assert spec_differences(old, now) == ["fixed"]  # would mix the two worlds: refused
    pinned = SweepSpec("lights", fixed={"preset": "paper", "num_cars": "4", "drive_on": "right",
                                        "arrived_heading_error": "zero", "goal_distance": "path",
                                        "light_view": "stop_line", "integration": "exact",
                                        "value_targets": "lambda_returns"})
    check_spec(pinned)
    assert spec_differences(old, pinned) == [] and saved_fixed(old)["drive_on"] == "right"


def test_the_scripted_drivers_beside_a_preset_section_drive_its_trials_world(monkeypatch):
    """The page's scripted baselines run in the world a sweep's trials ran in: every setting the
    preset changed after sweeps had run with it, read from an old sweep as it stood then."""
    from training.results import baselines
    from training.sweeps.spec import PINNED_WORLD

    asked = []
    monkeypatch.setattr(baselines, "scripted_violation_rate", lambda *args: asked.append(args) or 0.5)
    trial = {"status": "done", "report_first_seed": 1_500_000_000, "report_episodes": 200, "env_config.num_cars": 4}
    old = {"sweep": {"behaviour": "lights", "grid": {}, "fixed": {"preset": "paper", "num_cars": "4"}},
           "trials": [trial]}
    got = baselines.lights_baselines(old, [])
    assert set(got) == {f"{d}/red_light_violation_rate" for d in baselines.SCRIPTED_BASELINES}
    assert all(args[4] == "paper" and dict(args[5]) == PINNED_WORLD for args in asked)
    asked.clear()
    now = {**old, "sweep": {**old["sweep"], "fixed": {"preset": "paper", "num_cars": "4", "drive_on": "left",
                                                      "light_view": "axis_point", "integration": "euler"}}}
    baselines.lights_baselines(now, [])
    world = dict(asked[0][5])
    assert (world["drive_on"], world["light_view"], world["integration"]) == ("left", "axis_point", "euler")
