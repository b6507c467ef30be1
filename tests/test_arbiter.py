"""The original trainer's runs on the results page (``training/results/arbiter.py``): read from
their carried folders, and the noise claim decided by the page's one rule only from finished,
evaluated runs with two or more seeds at both ends."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from training.results.arbiter import (arbiter_cell, arbiter_section, load_driver_reports, load_original_runs,
                                      noise_verdict)
from training.results.data import ResultsError

COMMITTED = Path(__file__).resolve().parents[1] / "assets" / "original"


def _run(folder: Path, noise: float, seed: int, violations: float | None, done: int | None = None) -> None:
    epochs = 75 if noise < 1 else 50
    here = folder / f"noise{noise}_seed{seed}"
    here.mkdir(parents=True)
    (here / "run.json").write_text(json.dumps({"seed": seed, "epochs": epochs, "env_kwargs": {"lidar_noise": noise}}))
    done = epochs if done is None else done
    (here / "state.json").write_text(json.dumps({"epochs_done": done, "joint_steps": done * 32000,
                                                 "car_decisions": done * 126000}))
    if violations is not None:
        _report(here, violations, done, 0.01)


def _report(here: Path, violations: float, done: int, half: float) -> None:
    (here / "report.json").write_text(json.dumps({
        "red_light_violation_rate": violations, "success_rate": 0.9, "collision_rate": 0.05, "epochs": done,
        "episodes": 200, "first_seed": 1_500_000_000, "intervals": {"red_light_violation_rate": {"half_width": half}}}))


def test_no_verdict_without_both_ends_and_two_paired_seeds(tmp_path):
    _run(tmp_path, 0.25, 0, 0.02)
    assert noise_verdict(load_original_runs(tmp_path))[0] == "not run yet"
    _run(tmp_path, 1.0, 0, 0.01)
    assert noise_verdict(load_original_runs(tmp_path))[0] == "no interval yet"
    _run(tmp_path, 0.25, 1, 0.03)
    _run(tmp_path, 1.0, 2, 0.00)  # seed 2 has no partner at 0.25: one paired seed still
    assert noise_verdict(load_original_runs(tmp_path))[0] == "no interval yet"


@pytest.mark.parametrize("low, high, verdict, falls", [
    ((0.10, 0.12, 0.11), (0.02, 0.03, 0.01), "reproduced", 3),
    ((0.02, 0.03, 0.01), (0.10, 0.12, 0.11), "opposite", 0),
    ((0.05, 0.10, 0.02), (0.09, 0.01, 0.06), "not detected", 1),
])
def test_the_paired_difference_decides_by_the_pages_rule(tmp_path, low, high, verdict, falls):
    for seed, (a, b) in enumerate(zip(low, high)):
        _run(tmp_path, 0.25, seed, a)
        _run(tmp_path, 1.0, seed, b)
    got, words = noise_verdict(load_original_runs(tmp_path))
    assert got == verdict and "paired by seed (3 seeds)" in words
    assert f"; {falls} of 3 seeds fall" in words and ", p = 0." in words
    if verdict == "not detected":
        # the differences +0.04, -0.09, +0.04: mean -0.003, too small against their spread to tell
        assert "the interval allows a fall of up to" in words and "a planning estimate" in words


def test_unfinished_or_unevaluated_runs_are_shown_but_do_not_count(tmp_path):
    _run(tmp_path, 0.25, 0, 0.10)
    _run(tmp_path, 0.25, 1, 0.12, done=64)  # stopped part-way: evaluated at epoch 64
    _run(tmp_path, 1.0, 0, None)  # finished, not evaluated
    _run(tmp_path, 1.0, 1, 0.02)
    runs = load_original_runs(tmp_path)
    assert [(r.lidar_noise, r.seed) for r in runs] == [(0.25, 0), (0.25, 1), (1.0, 0), (1.0, 1)]
    assert noise_verdict(runs)[0] == "no interval yet"  # one seed (0 at 0.25, 1 at 1.0): unpaired
    page = "\n".join(arbiter_section(runs))
    assert "| `noise0.25_seed1` | 0.25 | 1 | 64 of 75 |" in page and "| 64 | 0.120 ± 0.010 |" in page
    assert "| `noise1.0_seed0` | 1.0 | 0 | 50 of 50 |" in page and "not evaluated" in page
    assert arbiter_cell(runs).startswith("**no interval yet** ([The paper's own code, in its own world]"
                                         "(#the-papers-own-code-in-its-own-world))")


def test_an_unreadable_run_names_its_folder(tmp_path):
    _run(tmp_path, 0.25, 0, 0.1)
    (tmp_path / "noise0.25_seed0" / "state.json").write_text("{")
    with pytest.raises(ResultsError, match="noise0.25_seed0"):
        load_original_runs(tmp_path)


def test_the_committed_runs_read():
    runs = load_original_runs(COMMITTED)
    assert runs and all(r.epochs_done <= r.epochs for r in runs)
    assert {r.lidar_noise for r in runs} <= {0.25, 1.0}
    drivers = load_driver_reports(COMMITTED)
    assert {d.driver for d in drivers} <= {"full-throttle", "random", "rule"}


def test_training_curves_are_read_from_each_runs_log_and_drawn(tmp_path):
    runs_dir, figures = tmp_path / "runs", tmp_path / "figures"
    _run(runs_dir, 0.25, 0, 0.1)
    _run(runs_dir, 1.0, 0, None, done=2)
    (runs_dir / "noise0.25_seed0" / "progress.csv").write_text(
        "epoch,joint_steps,car_decisions,episodes,episode_return,entropy,kl,stop_iter,seconds\n"
        "1,32000,110000,1280,-1.5,2.5,0.1,19.0,200\n2,32000,111000,1281,-0.5,2.4,0.1,19.0,201\n")
    runs = load_original_runs(runs_dir)
    assert runs[0].curve == ((32000, -1.5), (64000, -0.5))  # joint steps so far, the epoch's mean return
    assert runs[1].curve == ()  # no log kept: no line
    text = "\n".join(arbiter_section(runs, figures, "images/results"))
    assert "![The original trainer's training curves](images/results/original_training.png)" in text
    assert (figures / "original_training.png").stat().st_size > 0
    assert runs[0].violations == ()
    (runs_dir / "noise0.25_seed0" / "curve.csv").write_text(
        "epoch,joint_steps,episodes,first_seed,red_light_violation_rate,success_rate,collision_rate\n"
        "5,160000,100,1000000000,0.40,0.8,0.2\n10,320000,100,1000000000,0.20,0.9,0.1\n")
    runs = load_original_runs(runs_dir)
    assert runs[0].violations == ((160000, 0.4), (320000, 0.2))
    assert "selection episodes" in "\n".join(arbiter_section(runs, figures, "images/results"))
    (runs_dir / "noise0.25_seed0" / "progress.csv").unlink()
    figures2 = tmp_path / "none"
    assert "training curves" not in "\n".join(arbiter_section(load_original_runs(runs_dir), figures2))
    assert not figures2.exists()


def test_runs_of_other_commands_are_not_read_as_noise_runs(tmp_path):
    """The lone car's turning-junction run (noise 0, one car) or an 8-car run in the same folder
    stays out of the noise claim's runs."""
    _run(tmp_path, 0.25, 0, 0.02)
    for name, kwargs in (("lone", {"lidar_noise": 0.0, "nagents": 1, "turns": True}),
                         ("eight", {"lidar_noise": 0.25, "nagents": 8, "turns": False})):
        here = tmp_path / name
        here.mkdir()
        (here / "run.json").write_text(json.dumps({"seed": 0, "epochs": 60, "env_kwargs": kwargs}))
        (here / "state.json").write_text(json.dumps({"epochs_done": 1, "joint_steps": 32000,
                                                     "car_decisions": 32000}))
    assert [r.name for r in load_original_runs(tmp_path)] == ["noise0.25_seed0"]


def _driver(folder: Path, name: str, violations: float, first_seed: int = 1_500_000_000, cars: int = 4,
            turns: bool = False, file: str | None = None) -> None:
    here = folder / "drivers"
    here.mkdir(parents=True, exist_ok=True)
    (here / (file or f"{name}.json")).write_text(json.dumps({
        "world": "original", "driver": name, "cars_per_episode": cars, "turns": turns, "episodes": 200,
        "first_seed": first_seed, "red_light_violation_rate": violations,
        "intervals": {"red_light_violation_rate": {"half_width": 0.05}}}))


def test_scripted_drivers_on_the_same_episodes_are_what_the_runs_are_read_against(tmp_path):
    _run(tmp_path, 0.25, 0, 0.02)
    _run(tmp_path, 1.0, 0, 0.40)  # its interval (+-0.01) reaches above the lowest rule-free rate, 0.38
    _run(tmp_path, 1.0, 1, 0.01, done=20)  # unfinished: shown, not counted
    assert "Scripted drivers" not in "\n".join(arbiter_section(load_original_runs(tmp_path)))
    _driver(tmp_path, "full-throttle", 0.5)
    _driver(tmp_path, "random", 0.38)
    _driver(tmp_path, "rule", 0.01)
    _driver(tmp_path, "full-throttle", 0.6, file="other-episodes.json", first_seed=1_500_000_500)
    _driver(tmp_path, "full-throttle", 0.3, file="turning.json", cars=1, turns=True)  # another world
    drivers = load_driver_reports(tmp_path)
    assert len(drivers) == 5 and not any(d.driver == "drivers" for d in drivers)
    assert len(load_original_runs(tmp_path)) == 3  # the drivers' folder is no run
    text = "\n".join(arbiter_section(load_original_runs(tmp_path), drivers=drivers))
    line = next(x for x in text.splitlines() if x.startswith("**Scripted drivers"))
    assert "full-throttle 0.500 ± 0.050, random 0.380 ± 0.050" in line and "light rule" in line and "0.010" in line
    assert "0.600" not in line and "0.300" not in line  # other episodes, another world: left out
    assert "1 of the 2 finished runs enter on red less than every rule-free driver" in line
    assert "learns to stop" not in line
    _run(tmp_path / "all", 0.25, 0, 0.02)
    _run(tmp_path / "all", 1.0, 0, 0.10)
    _driver(tmp_path / "all", "full-throttle", 0.5)
    both = tmp_path / "all"
    text = "\n".join(arbiter_section(load_original_runs(both), drivers=load_driver_reports(both)))
    assert "2 of the 2 finished runs" in text and "learns to stop at red at every noise level it ran" in text
    (tmp_path / "drivers" / "broken.json").write_text(json.dumps({"world": "ours", "driver": "rule"}))
    with pytest.raises(ResultsError, match="broken.json"):
        load_driver_reports(tmp_path)


def _lone(folder: Path, seed: int, violations: float | None, done: int = 60) -> None:
    here = folder / f"turns_seed{seed}"
    here.mkdir(parents=True)
    (here / "run.json").write_text(json.dumps({"seed": seed, "epochs": 60, "env_kwargs": {
        "lidar_noise": 0.0, "nagents": 1, "turns": True}}))
    (here / "state.json").write_text(json.dumps({"epochs_done": done, "joint_steps": done * 32000,
                                                 "car_decisions": done * 32000}))
    if violations is not None:
        _report(here, violations, done, 0.07)


def test_the_lone_car_runs_are_read_apart_and_judged_against_the_turning_worlds_drivers(tmp_path):
    from training.results.lone_car_arbiter import lone_car_cell, lone_car_section, lone_car_verdict
    from training.results.original_runs import load_lone_car_runs

    assert "No run carried yet" in "\n".join(lone_car_section([], []))
    assert lone_car_verdict([], [])[0] == "not run yet"
    _run(tmp_path, 0.25, 0, 0.02)
    _lone(tmp_path, 0, 0.465)
    _lone(tmp_path, 1, 0.2, done=30)  # unfinished: shown, not counted
    runs = load_lone_car_runs(tmp_path)
    assert [r.name for r in runs] == ["turns_seed0", "turns_seed1"]
    assert [r.name for r in load_original_runs(tmp_path)] == ["noise0.25_seed0"]  # each claim its own runs
    assert lone_car_verdict(runs, [])[0] == "no reference yet"
    _driver(tmp_path, "full-throttle", 0.1)  # the 4-car junction's: not this world's reference
    _driver(tmp_path, "full-throttle", 0.465, file="full-throttle-turns.json", cars=1, turns=True)
    _driver(tmp_path, "random", 0.43, file="random-turns.json", cars=1, turns=True)
    drivers = load_driver_reports(tmp_path)
    assert lone_car_verdict(runs, drivers)[0] == "no interval yet"  # one finished seed
    _lone(tmp_path, 2, 0.455)
    runs = load_lone_car_runs(tmp_path)
    verdict, words = lone_car_verdict(runs, drivers)
    assert verdict == "reproduced" and "seeds finished and evaluated: 2" in words
    assert "full-throttle 0.465, random 0.430" in words and "0.100" not in words
    assert "not below every rule-free driver" in words and "as in the paper" in words
    assert lone_car_cell(runs, drivers).startswith(
        "**reproduced** ([The paper's own code on its lone car](#the-papers-own-code-on-its-lone-car)): ")
    text = "\n".join(lone_car_section(runs, drivers))
    assert "| `turns_seed1` | 1 | 30 of 60 |" in text and "--driver NAME --turns" in text
    assert "0 of the 2 finished runs enter on red less than every rule-free driver" in text
    stops = tmp_path / "stops"
    for seed, v in enumerate((0.02, 0.03, 0.01)):
        _lone(stops, seed, v)
    _driver(stops, "full-throttle", 0.465, cars=1, turns=True)
    got, words = lone_car_verdict(load_lone_car_runs(stops), load_driver_reports(stops))
    assert got == "opposite" and "stops for the light, unlike the paper" in words
    assert "each learnt to stop for the light" in "\n".join(lone_car_section(load_lone_car_runs(stops),
                                                                             load_driver_reports(stops)))
