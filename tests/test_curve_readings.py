"""Readings of a drawn learning curve (``box2d-driving curve FILE --readings``): each reading on
hand-built curves, the table of a sweep's and a run's curve file, and bad input."""

from __future__ import annotations

import csv
import math

import numpy as np
import pytest

from training.evaluation import curve_readings as cr
from training.evaluation.checkpoint_curve import CurveError
from training.sweeps import curves


def test_each_reading_of_a_hand_built_curve():
    d = np.arange(1, 21) * 1e6  # 20 checkpoints, 1 M .. 20 M decisions
    v = np.array([0.9, 0.2, 0.4, 0.5] + [0.5, 0.6] * 8)
    got = cr.readings(d[::-1], v[::-1])  # any order: sorted by decisions first
    assert got["checkpoints"] == 20 and got["first"] == 0.9
    assert got["early_low"] == 0.2  # the first 10 %: 1 M and 2 M
    assert (got["settled_low"], got["settled_high"]) == (0.4, 0.6)  # from 3 M (15 %) on
    # 25 % of 20 checkpoints: the 5 ending at 10 M (6 M .. 10 M) and the last 5 (16 M .. 20 M)
    assert got["half_mean"] == pytest.approx(np.mean([0.6, 0.5, 0.6, 0.5, 0.6]))
    assert got["end_mean"] == pytest.approx(np.mean([0.6, 0.5, 0.6, 0.5, 0.6]))
    assert got["late_change"] == pytest.approx(0.0, abs=0.02)


def test_missing_values_are_skipped_and_an_empty_curve_reads_nan():
    d = np.array([1.0, 2.0, 3.0, 4.0])
    got = cr.readings(d, np.array([np.nan, 0.3, 0.4, 0.5]))
    assert got["checkpoints"] == 3 and got["first"] == 0.3
    assert got["early_low"] == 0.3  # no finite checkpoint at or before 10 % of 4: the first one's
    empty = cr.readings(d, np.full(4, np.nan))
    assert empty["checkpoints"] == 0 and all(math.isnan(empty[k]) for k in empty if k != "checkpoints")


def test_windows_are_checked_shares():
    with pytest.raises(CurveError, match="ReadingWindows.window"):
        cr.ReadingWindows(window=0.0)
    with pytest.raises(CurveError, match="ReadingWindows.early"):
        cr.ReadingWindows(early=1.5)


def _write(path, rows):
    with open(path, "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(rows[0]))
        w.writeheader()
        w.writerows(rows)


def _sweep_rows():
    """A sweep's curve file as ``box2d-driving curve SWEEP`` writes it: two trials, a grid column
    before the metrics, a sign-free Pearson column."""
    rows = []
    for trial, noise, sign in (("t_noise=0_seed=0", "0", 1.0), ("t_noise=0.5_seed=0", "0.5", -1.0)):
        for i in range(1, 9):
            rows.append({"trial": trial, "seed": 0, "lidar_noise": noise, "decisions": i * 1000,
                         "agent_steps": i * 600.0, "episodes": 10, "first_seed": 1_000_000_000,
                         "success_rate": 0.1 * i, "communication.pearson_heading_change_bit": sign * 0.2})
    return rows


def test_the_table_of_a_sweeps_curve_file(tmp_path, capsys):
    path = tmp_path / "curves.csv"
    _write(path, _sweep_rows())
    trials, columns = cr.read_curve_file(path)
    assert list(trials) == ["t_noise=0_seed=0", "t_noise=0.5_seed=0"]
    assert columns == ["success_rate", "communication.pearson_heading_change_bit"]  # not the grid column
    lines = cr.readings_table(trials, columns)
    assert len(lines) == 2 + 2 * 2
    # early low: no checkpoint in the first 10 %, so the first one's; the range from 15 % (1,200) on;
    # 2 checkpoints ending at half (3,000 and 4,000), the last 2; late change over 4,000 .. 8,000
    assert lines[2] == "| t_noise=0_seed=0 | success_rate | 8 | 0.10 | 0.10 | 0.20 | 0.80 | 0.35 | 0.75 | +0.400 |"
    # the bit's sign is the speaker's convention: both trials read +0.20
    assert "| t_noise=0.5_seed=0 | \\|communication.pearson_heading_change_bit\\| | 8 | 0.20 |" in lines[5]
    # through the CLI, on the sweep folder (its curves.csv) and on the file itself
    assert curves.main([str(tmp_path), "--readings", "--metric", "success_rate"]) == 0
    out = capsys.readouterr().out
    assert str(path) in out and out.count("| success_rate |") == 2 and "pearson" not in out


def test_a_run_curve_is_one_trial_named_after_its_run(tmp_path, capsys):
    folder = tmp_path / "my_run" / "checkpoint_curve"
    folder.mkdir(parents=True)
    rows = [{k: v for k, v in r.items() if k not in ("trial", "seed", "lidar_noise")} for r in _sweep_rows()[:8]]
    _write(folder / "curve.csv", rows)
    assert curves.main([str(tmp_path / "my_run"), "--readings"]) == 0
    assert "| my_run | success_rate | 8 |" in capsys.readouterr().out


def test_bad_readings_input_gets_one_clear_error(tmp_path, capsys):
    assert curves.main([str(tmp_path), "--readings"]) == 2
    assert "no curve file" in capsys.readouterr().err
    path = tmp_path / "curves.csv"
    path.write_text("a,b\n1,2\n")
    assert curves.main([str(path), "--readings"]) == 2
    assert "not a curve file" in capsys.readouterr().err
    rows = _sweep_rows()
    rows[3]["success_rate"] = "lots"
    _write(path, rows)
    assert curves.main([str(path), "--readings"]) == 2
    assert "line 5: success_rate='lots' is not a number" in capsys.readouterr().err
    _write(path, _sweep_rows())
    assert curves.main([str(path), "--readings", "--metric", "nope"]) == 2
    assert "--metric nope: not a column" in capsys.readouterr().err
    for flag in (["--overwrite"], ["--finished"], ["--out", str(tmp_path / "o")], ["--episodes", "20"],
                 ["--seed", "1000000000"]):
        assert curves.main([str(path), "--readings", *flag]) == 2
        assert "--readings draws nothing" in capsys.readouterr().err
    assert curves.main([str(tmp_path), "--metric", "success_rate"]) == 2
    assert "only with --readings" in capsys.readouterr().err
    assert not (tmp_path / "o").exists()


def test_trials_the_summary_does_not_list_as_done_are_marked_part_way(tmp_path, capsys):
    """A committed curve file may hold the curve so far of a trial stopped and carried: its
    readings are shares of where it stopped, so the table marks it (by the summary beside it)."""
    import json

    path = tmp_path / "curves" / "my-sweep.csv"
    path.parent.mkdir()
    _write(path, _sweep_rows())
    summary = tmp_path / "my-sweep.json"
    summary.write_text(json.dumps({"sweep": {}, "trials": [{"trial": "t_noise=0_seed=0", "status": "done"}]}))
    assert cr.summary_of(path) == summary
    assert cr.unfinished_trials(summary, ["t_noise=0_seed=0", "t_noise=0.5_seed=0"]) == {"t_noise=0.5_seed=0"}
    assert curves.main([str(path), "--readings", "--metric", "success_rate"]) == 0
    out = capsys.readouterr().out
    assert "| t_noise=0_seed=0 | success_rate |" in out
    assert "| t_noise=0.5_seed=0 (part-way) | success_rate |" in out and f"not done by {summary}" in out
    # once it lands, nothing is marked
    summary.write_text(json.dumps({"sweep": {}, "trials": [{"trial": t, "status": "done"}
                                                           for t in ("t_noise=0_seed=0", "t_noise=0.5_seed=0")]}))
    assert curves.main([str(path), "--readings"]) == 0
    assert "part-way" not in capsys.readouterr().out
    # a sweep folder's curves.csv reads its summary.json; a run's curve has none
    sweep = tmp_path / "sweep"
    sweep.mkdir()
    assert cr.summary_of(sweep / "curves.csv") is None
    (sweep / "summary.json").write_text("[]")
    assert cr.summary_of(sweep / "curves.csv") == sweep / "summary.json"
    with pytest.raises(CurveError, match="not a sweep summary"):
        cr.unfinished_trials(sweep / "summary.json", ["a"])
    assert cr.unfinished_trials(None, ["a"]) == set()
