"""``box2d-driving reproduce --reevaluate`` (``training/results/reevaluate.py``): a landed trial's
report columns measured again from the weights it kept.

The fixture ``tests/data/reevaluate`` is a real landed trial: a one-trial lights sweep (4 cars,
noise 0.25, fine-tuned 160 decisions from the shipped noise-0.5 policy, 3 report episodes) run by
``box2d-driving sweep`` and landed by ``TrialLander`` (summary row, curve, kept actor), committed
as it was written. Re-evaluating it must give back every report column the sweep stored, by the
sweep's own path (trial worker -> Ray Tune -> summary row), bit for bit."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from training.results.reevaluate import kept_count, reevaluate_summary, report_columns_of

FIXTURE = Path(__file__).parent / "data" / "reevaluate"
NAME = "lights-paper"
TRIAL = "lights_lidar_noise=0.25_seed=0"
POLICIES = Path(__file__).resolve().parents[1] / "assets" / "policies"


@pytest.fixture()
def summaries(tmp_path: Path) -> Path:
    folder = tmp_path / "sweeps"
    shutil.copytree(FIXTURE, folder)
    return folder


def _row(folder: Path) -> dict:
    return json.loads((folder / f"{NAME}.json").read_text())["trials"][0]


def _cli(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "box2d_driving", "reproduce", *args],
                          capture_output=True, text=True, env={**os.environ, "SDL_VIDEODRIVER": "dummy"})


def test_reevaluating_a_landed_trial_gives_back_every_stored_column(summaries, tmp_path):
    before = _row(summaries)
    done = _cli("--reevaluate", "--only", "traffic-lights-paper", "--summaries", str(summaries),
                "--out", str(tmp_path / "page.md"))
    assert done.returncode == 0, done.stderr
    assert f"{NAME}: 1 trials re-evaluated, 0 kept no weights" in done.stdout
    assert f"{TRIAL}: every report column as it was" in done.stdout
    after = _row(summaries)
    assert list(after) == list(before)  # same columns, same order
    for key, value in before.items():
        if key == "eval_seconds":  # how long the evaluation took: measured again
            continue
        assert after[key] == value or (value != value and after[key] != after[key]), key
    page = (tmp_path / "page.md").read_text()
    assert "final weights kept for 1 of the 1" in page


def test_a_changed_or_missing_column_is_measured_again_and_named(summaries):
    path = summaries / f"{NAME}.json"
    saved = json.loads(path.read_text())
    row = saved["trials"][0]
    truth = {k: row[k] for k in ("red_light_violation_rate", "junction_entries", "collision_rate")}
    row["red_light_violation_rate"] = 0.5  # as if the metric code had changed since
    row["junction_entries"] = 99
    del row["collision_rate"]  # as if a metric were added since the sweep ran
    row["retired_metric"] = 1.0  # and one the evaluation no longer writes
    path.write_text(json.dumps(saved))
    result = reevaluate_summary(path, log=lambda _: None)
    assert result.reevaluated == [TRIAL] and result.not_kept == []
    assert sorted(result.changed[TRIAL]) == ["junction_entries", "red_light_violation_rate"]
    assert result.added[TRIAL] == ["collision_rate"] and result.removed[TRIAL] == ["retired_metric"]
    after = _row(summaries)
    assert {k: after[k] for k in truth} == truth and "retired_metric" not in after
    assert "collision_rate" in (summaries / f"{NAME}.csv").read_text().splitlines()[0].split(",")
    line = "\n".join(result.lines())
    assert "changed " in line and "junction_entries" in line and "red_light_violation_rate" in line
    assert "no longer measured retired_metric" in line


def test_a_trial_without_kept_weights_keeps_its_row_and_is_counted(summaries, tmp_path):
    shutil.rmtree(summaries / "weights")
    before = (summaries / f"{NAME}.json").read_bytes()
    result = reevaluate_summary(summaries / f"{NAME}.json", log=lambda _: None)
    assert result.not_kept == [TRIAL] and result.reevaluated == []
    assert (summaries / f"{NAME}.json").read_bytes() == before
    assert kept_count(summaries / f"{NAME}.json", [_row(summaries)]) == (0, 1)
    done = _cli("--summaries", str(summaries), "--out", str(tmp_path / "page.md"))
    assert done.returncode == 0, done.stderr
    assert "final weights kept for 0 of the 1" in (tmp_path / "page.md").read_text()


def test_unreadable_kept_weights_stop_with_one_line_and_change_nothing(summaries, tmp_path):
    model = summaries / "weights" / NAME / TRIAL / "model.safetensors"
    model.write_bytes(model.read_bytes()[:1000])
    before = {p.name: p.read_bytes() for p in summaries.glob(f"{NAME}.*")}
    done = _cli("--reevaluate", "--only", "traffic-lights-paper", "--summaries", str(summaries),
                "--out", str(tmp_path / "page.md"))
    assert done.returncode == 2
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "could not be re-evaluated" in lines[0] and TRIAL in lines[0], done.stderr
    assert {p.name: p.read_bytes() for p in summaries.glob(f"{NAME}.*")} == before
    assert not (tmp_path / "page.md").exists()


@pytest.mark.parametrize("args, message", [
    (["--only", "traffic-lights"], "--only goes with --run or --reevaluate"),
    (["--reevaluate", "--run"], "choose one"),
    (["--reevaluate", "x.json"], "give no summary files"),
])
def test_reevaluate_flags_that_do_not_go_together(args, message):
    done = _cli(*args)
    assert done.returncode == 2 and message in done.stderr


def test_only_a_rule_without_a_summary_is_an_error(summaries, tmp_path):
    done = _cli("--reevaluate", "--only", "pedestrians", "--summaries", str(summaries),
                "--out", str(tmp_path / "page.md"))
    assert done.returncode == 2 and "no summary" in done.stderr and "crosswalk.json" in done.stderr


def test_report_columns_leave_out_what_says_which_trial_it_is():
    row = _row(FIXTURE)
    columns = report_columns_of(row, {"lidar_noise": ["0.25"]})
    assert "red_light_violation_rate" in columns and "env_config.num_cars" in columns
    assert not {"trial", "seed", "decisions", "wall_s", "report_first_seed", "lidar_noise"} & set(columns)


@pytest.mark.parametrize("run", ["traffic_lights_4cars_noise05", "fast_lanes_10cars"])
def test_the_torch_loader_acts_from_kept_weights_as_from_the_run(run, tmp_path):
    from training.runs.inference import load_policy
    from training.sweeps.kept import keep_final_weights

    kept = keep_final_weights(POLICIES / run, tmp_path / "kept")
    a, b = load_policy(kept), load_policy(POLICIES / run)
    env = b.make_env()
    obs, _ = env.reset(seed=1_500_000_000)
    batch = np.stack([obs[k] for k in sorted(obs)])
    assert np.array_equal(a.actions(batch), b.actions(batch))
    if run.startswith("fast_lanes"):  # the spline stage too
        space = env.spline_observation_space
        space.seed(0)
        obs0 = np.stack([space.sample() for _ in range(6)])
        assert np.array_equal(a.choose_paths(obs0), b.choose_paths(obs0))
    env.close()
