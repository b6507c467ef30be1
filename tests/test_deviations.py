"""The claims table's list of what a row ran differently from the paper's command."""

from __future__ import annotations

from training.results.deviations import PaperCommand, TrialSettings, deviations, section_settings

PAPER_WORLD = TrialSettings("intersection-v0", 1e-4, -1.0, None, "paper", "original", "euler", "rewards_to_go")


def test_a_run_as_the_paper_command_has_no_deviation():
    assert deviations(PAPER_WORLD, PaperCommand(1e-4)) == []
    turns = TrialSettings("intersection-v0", 1e-3, -1.0, None, "paper-turns", "original", "euler", "rewards_to_go")
    assert deviations(turns, PaperCommand(1e-3)) == []


def test_each_deviation_is_named_with_the_papers_value():
    ours = TrialSettings("real-junction-v0", 0.01, -3.0, "assets/policies/real_junction_8cars", None, "relu")
    found = deviations(ours, PaperCommand(1e-4, start=None, maps="nuScenes junctions"))
    assert found == [
        "our world and update, not the paper's code's (arrived cars leave, several passes over each update's data: "
        "[what differs](paper_world.md#the-differences))",
        "Helsinki junctions from OpenStreetMap (the paper's: nuScenes junctions)",
        "entropy 0.01 (the paper's 1e-4)",
        "collision reward -3 (the paper's -1)",
        "starts from `assets/policies/real_junction_8cars` (the paper's: not stated)",
        "our LiDAR encoder (`lidar_encoder=relu`; the paper's code's: two linear strided convolutions)"]


def test_a_preset_run_pinned_to_our_integration_and_value_targets_says_so():
    pinned = TrialSettings("intersection-v0", 1e-4, -1.0, None, "paper", "original", "exact", "lambda_returns")
    assert deviations(pinned, PaperCommand(1e-4)) == [
        "cars moved by exact integration (the paper's code: Euler steps at each 0.1 s step's starting speed)",
        "a critic trained on lambda-returns (the paper's code: discounted rewards-to-go)"]


def test_the_start_is_compared_both_ways():
    fine_tuned = PaperCommand(1e-4, start="from its 4-car noise-0 model")
    assert deviations(PAPER_WORLD, fine_tuned) == ["starts from scratch (the paper's: from its 4-car noise-0 model)"]
    ours = TrialSettings("intersection-v0", 1e-4, -1.0, "assets/x", "paper", "original", "euler", "rewards_to_go")
    assert deviations(ours, PaperCommand(1e-4)) == ["starts from `assets/x` (the paper's: from scratch)"]


def test_a_sections_settings_come_from_its_sweep_command():
    """Read from the trial the command builds: its own --set values and the env's defaults."""
    right_of_way = section_settings("right-of-way-paper-32M")
    assert right_of_way == TrialSettings("real-junction-v0", 1e-4, -3.0, "assets/policies/real_junction_8cars",
                                         None, "relu", None, "lambda_returns")
    lights = section_settings("traffic-lights-paper-left")  # pins what the preset since changed
    assert (lights.preset, lights.entropy, lights.collision_reward, lights.init_from, lights.integration,
            lights.value_targets) == ("paper", 1e-4, -1.0, None, "exact", "lambda_returns")
    turns = section_settings("traffic-lights-paper-turns-1car")
    assert (turns.preset, turns.entropy, turns.integration, turns.value_targets) == \
        ("paper-turns", 1e-3, "euler", "rewards_to_go")
    lanes = section_settings("lanes-paper-16M")  # a bilevel run: its acceleration stage's settings
    assert (lanes.env_id, lanes.entropy, lanes.preset) == ("intersection-spline-v0", 0.01, None)
