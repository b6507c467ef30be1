"""Training, selection and report episode seeds stay apart: reports never use the others."""

from __future__ import annotations

import json

import pytest

from box2d_driving.config import ConfigError
from training.common.seeds import MAX_RUN_SEED, REPORT, SELECTION, TRAINING, SeedError, which


def test_the_three_ranges_are_disjoint_and_ordered():
    ranges = [TRAINING, SELECTION, REPORT]
    for a, b in zip(ranges, ranges[1:]):
        assert a.stop <= b.start
    assert REPORT.stop <= 2**31  # any seed reset() takes
    assert [which(r.start) for r in ranges] == ["training", "selection", "report"]
    assert which(REPORT.stop) == "none" and (True not in REPORT)
    assert list(REPORT.episodes(3)) == [REPORT.start, REPORT.start + 1, REPORT.start + 2]
    with pytest.raises(SeedError, match="report seeds are"):
        REPORT.episodes(2, REPORT.stop - 1)  # the second one would leave the range


@pytest.mark.parametrize("seed", [0, 10_000, SELECTION.start, SELECTION.stop - 5, REPORT.stop])
def test_evaluate_refuses_episodes_that_are_not_report_seeds(tmp_path, capsys, seed):
    from training.evaluation import evaluate

    out = tmp_path / "eval"
    assert evaluate.main(["--checkpoint", "rule", "--episodes", "2", "--seed", str(seed), "--out", str(out)]) == 2
    assert "report seeds are" in capsys.readouterr().err
    assert not out.exists()


def test_evaluate_reports_on_report_seeds_by_default(tmp_path):
    from training.evaluation import evaluate

    out = tmp_path / "eval"
    assert evaluate.main(["--checkpoint", "rule", "--episodes", "2", "--out", str(out)]) == 0
    metrics = json.loads((out / "metrics.json").read_text())
    assert metrics["seed"] == REPORT.start and metrics["seed_set"] == "report"


def test_training_never_draws_selection_or_report_episodes():
    from tests.helpers import tiny_train_config
    from training.trainers.trainer import make_vec_env

    with pytest.raises(ConfigError, match="seed"):
        tiny_train_config(seed=MAX_RUN_SEED + 1)
    venv = make_vec_env(tiny_train_config())
    try:
        venv.seed(TRAINING.stop - 100)  # the last instances' seeds still training seeds
        with pytest.raises(SeedError, match="training seeds"):
            venv.seed(TRAINING.stop - 1)
        with pytest.raises(SeedError):
            venv.seed(REPORT.start)
    finally:
        venv.close()
