"""The pieces several of the results page's rules share (:mod:`training.results.sections` lists the
rules): derived measures (a correlation's size, the success lost with messages unheard, the lanes'
one-sided offset), table columns, figures, statements, the paper's claims and the runs it made, and
:func:`lanes_4_vs_8`, the section every lanes run at the paper's car counts is.
"""

from __future__ import annotations

from typing import Any

from training.evaluation import figure_data as fd
from training.original.commands import TrainerSettings
from training.results.baselines import right_of_way_baselines, scripted_baselines
from training.results.data import Difference, HistogramMean, PaperValue, Preferred, Size
from training.results.figures import against_noise_figure, bars_figure, distribution_figure, gap_figure
from training.results.page_section import Section
from training.results.statements import (Statement, above_statement, apart_statement, noise_trend_statement,
                                         scripted_baseline_statement)

__all__ = ["AGAINST_NOISE", "COMMUNICATION_BASELINE", "COMMUNICATION_BUDGET", "COMMUNICATION_CLAIM",
           "COMMUNICATION_FIGURE",
           "COMMUNICATION_METRICS", "COMMUNICATION_STATEMENTS", "DENSER_BUDGET", "FAST_LANES_R", "LANE_SIDE_LEVEL",
           "LANES_BASELINE", "LANES_BUDGET", "LANES_CURVE_EXTRA", "LANES_FIGURE", "LANES_METRICS",
           "LANES_NOISE_METRICS",
           "LANES_PAPER_CLAIM", "LIGHTS_BASELINE_STATEMENT", "LIGHTS_METRICS", "LIGHTS_NOISE_BUDGET",
           "LIGHTS_NOISE_FIGURE", "LIGHTS_NOISE_STATEMENTS", "ONE_SIDED", "ONE_SIDED_WORDS", "PEARSON",
           "SAFE_SHORTFALL_WORDS", "SUCCESS_LOST_UNHEARD", "SWEEP", "lanes_4_vs_8", "lanes_statements", "right_of_way",
           "turn_signals_12_cars"]


SWEEP = "box2d-driving sweep"
# which bit value a run's cars use for what is each run's own choice: the correlation's sign is
# arbitrary per seed, so its size is what is averaged
PEARSON = Size("communication.pearson_heading_change_bit")
# success lost when every message is replaced by silence, on the same report episodes: how much
# the listeners rely on the message
SUCCESS_LOST_UNHEARD = Difference("success_rate", "messages_unheard.success_rate")
# which side the fast cars take is each run's choice (seeds give +0.999 and -0.997): the size
FAST_LANES_R = Size("fast_lanes.pearson_r")
# lanes: how far off the road axis the cars drive, on one side. Defined before the paper-settings
# runs (after the 3-seed sweep had been looked at): the signed mean lane position in the junction,
# per seed, by size (the side is each run's choice). Cars on the axis, or on both sides in turn,
# give ~0; cars keeping to one side give their offset (+-1 at the road edges).
# From the lane samples (the summaries' lanes.one_sided_offset); summaries written before that
# column existed give it from the lane histogram's bin centres (within about 0.01 of it).
ONE_SIDED = Size(Preferred("lanes.one_sided_offset",
                           HistogramMean("lane_position_counts", tuple(float(b) for b in fd.LANE_BINS))))
# the communication measures drawn and stated against LiDAR noise
AGAINST_NOISE = (("communication.speaker_consistency_bits", "speaker consistency (bits)"),
                 (PEARSON, "|Pearson(heading change, bit)|"),
                 (SUCCESS_LOST_UNHEARD, "success lost with messages unheard"))
# the turn-signal rules' table columns, the paper's claim and its runs (every turn-signal section)
COMMUNICATION_METRICS = (*AGAINST_NOISE[:2], ("success_rate", "success"), AGAINST_NOISE[2])
COMMUNICATION_CLAIM = ("Speaker consistency and |Pearson(heading change, bit)| both rise with LiDAR noise: cars rely "
                       "more on the message when their perception is less reliable.")
COMMUNICATION_BUDGET = ("12 cars at LiDAR noise 0, 0.5 and 0.75, entropy 1e-4, 1,000 epochs of 32,000 joint steps "
                        "(32 M joint steps: up to 384 M car-decisions, fewer as arrived cars leave this junction)")
# every turn-signal section's figure and statements: the trend with noise, then whether the
# listeners rely on the message at each noise level
COMMUNICATION_FIGURE = against_noise_figure(AGAINST_NOISE)
# drivers whose bit says nothing (random bits; full throttle always sends 0) on the trials' own episodes
COMMUNICATION_BASELINE = scripted_baselines(
    "real-junction-v0", tuple(m for m, _ in AGAINST_NOISE[:2]),
    (("full-throttle", "full-throttle", "axis"), ("random", "random", "axis")), overrides=(("communication", True),))
COMMUNICATION_STATEMENTS = (noise_trend_statement(AGAINST_NOISE),
                            scripted_baseline_statement(AGAINST_NOISE[:2], claimed=False),
                            above_statement(SUCCESS_LOST_UNHEARD, "success lost with messages unheard",
                                            "the listeners rely on the message", "success rises without the message",
                                            level=0.0, level_text="zero",
                                            paper="The paper ties the listeners' reliance to noise (more with "
                                                  "noisier LiDAR), not to any one level: the comparison across "
                                                  "levels is this measure's noise-trend line (given once each level "
                                                  "has two or more seeds)."))
# the lights rules' table columns, and the paper's runs of them (from the original code's experiment list)
LIGHTS_METRICS = (("red_light_violation_rate", "red-light violations"), ("success_rate", "success"),
                  ("collision_rate", "collisions"))
# the lights noise grids' figure and statements (our default world's grid and the paper world's):
# violations and success against noise, the noise trend paired by seed, the rule-free drivers
LIGHTS_NOISE_FIGURE = against_noise_figure((("red_light_violation_rate", "red-light violations"),
                                            ("success_rate", "success")))
LIGHTS_BASELINE_STATEMENT = scripted_baseline_statement((("red_light_violation_rate", "red-light violations"),),
                                                        paper=-1)
LIGHTS_NOISE_STATEMENTS = (noise_trend_statement((("red_light_violation_rate", "4 cars, red-light violations"),),
                                                 paper=-1), LIGHTS_BASELINE_STATEMENT)
LIGHTS_NOISE_BUDGET = ("4 cars at LiDAR noise 0.25, 0.5 and 0.75 for 75 epochs and 1.0 for 50, entropy 1e-4; an epoch "
                       "is 32,000 joint steps, each a decision of every car (arrived cars stay): 75 epochs = 2.4 M "
                       "joint steps, about 9.6 M car-decisions")
DENSER_BUDGET = ("8 cars fine-tuned from the 4-car noise-0 policy for 500 epochs (16 M joint steps, about 128 M "
                 "car-decisions), entropy 1e-4; a 12-car run was described, 1,000 epochs more (its listed command "
                 "says 8 cars)")
# joint steps per trial of the paper's runs (epochs x 32,000): our trials' fraction of them
_EPOCH = TrainerSettings.steps_per_epoch
LIGHTS_NOISE_JOINT_STEPS, DENSER_JOINT_STEPS = 75 * _EPOCH, 500 * _EPOCH
# the lanes rules' table columns, figure, statements (fewer cars against 8) and the paper's runs
LANES_METRICS = (("lanes.majority_share", "crossings on the majority side"),
                 ("lanes.time_share_majority", "time on the majority side"),
                 ("lanes.mean_abs_lane_position", "mean |lane position|"), (ONE_SIDED, "one-sided offset"),
                 ("success_rate", "success"))
ONE_SIDED_WORDS = ("*One-sided offset*: the size of each seed's mean signed lane position in the junction (0 on "
                   "the axis or on both sides in turn, +-1 at the road edges); *mean |lane position|* counts "
                   "driving off the axis on either side.")
LANES_FIGURE = distribution_figure("lane_position_counts", fd.LANE_BINS,
                                   "lane position inside the junction, each seed mirrored so that its "
                                   "majority side is +",
                                   bars_figure("lanes.majority_share", "share on the majority side"))
# a one-sided offset above this (a tenth of the half-width, mean over seeds) is read as keeping to
# one side: the 2-car seeds of the 48-round sweep lie at 0.014-0.041, the 8-car ones at 0.33-0.39
LANE_SIDE_LEVEL = 0.1
# the one-sided offset of a learning curve: from the checkpoint's lane samples, not a histogram
LANES_CURVE_EXTRA = (("lanes.one_sided_offset", "one-sided offset"),)
# the measures compared between noise levels (the paper: sharper peaks on one side with noise, then
# poor convergence past a threshold)
LANES_NOISE_METRICS = ((ONE_SIDED, "one-sided offset"), ("lanes.time_share_majority", "time on the majority side"))
# the claim both paper-car-count lanes sections test (our path choice and the paper's)
LANES_PAPER_CLAIM = ("With 8 cars and noisy LiDAR, cars settle on one side of the road; with fewer cars they do not "
                     "(the paper's runs: 4 and 8 cars).")
LANES_BUDGET = ("4 and 8 cars, LiDAR noise 0 to 1.0, entropy 1e-4, 150 to 1,000 epochs of 32,000 joint steps "
                "(4.8-32 M joint steps, each a decision of every car), 1,200 spline episodes per epoch")


# drivers with no lane rule, on random paths (the light rule knows nothing of lanes either), on the
# lanes trials' own report episodes
LANES_BASELINE_METRICS = (("lanes.majority_share", "crossings on the majority side"), (ONE_SIDED, "one-sided offset"))
LANES_BASELINE = scripted_baselines("intersection-spline-v0", tuple(m for m, _ in LANES_BASELINE_METRICS), (
    ("full-throttle on random paths", "full-throttle", "random"), ("random on random paths", "random", "random"),
    ("light rule on random paths", "rule", "random")))
LANES_BASELINE_STATEMENT = scripted_baseline_statement(LANES_BASELINE_METRICS, claimed=False)


def lanes_statements(fewer: str, paper_counts: bool) -> tuple[Statement, ...]:
    """Fewer cars (``fewer``) against 8: the majority share and the one-sided offset, intervals
    apart. ``paper_counts``: the paper's own car counts (4 and 8), where its claim is "lanes with
    8, none with 4": then whether each count keeps to one side is said, and the offsets'
    difference alone names no agreement with the paper."""
    return (apart_statement("num_cars", fewer, "8", "lanes.majority_share", "crossings on the majority side",
                            "more one-sided with 8 cars"),
            apart_statement("num_cars", fewer, "8", ONE_SIDED, "one-sided offset",
                            "further off the axis on one side with 8 cars", judged=not paper_counts)) + ((
            above_statement(ONE_SIDED, "one-sided offset", "the cars keep to one side",
                            "the cars drive on the axis or on both sides", level=LANE_SIDE_LEVEL,
                            level_text=f"{LANE_SIDE_LEVEL:g}",
                            paper=f"The paper: lanes with 8 cars, none with {fewer}. *Keep to one side*: the "
                                  f"one-sided offset's interval above {LANE_SIDE_LEVEL:g} of the half-width."),)
            if paper_counts else ()) + (LANES_BASELINE_STATEMENT,)


def lanes_4_vs_8(key: str, title: str, match: tuple[tuple[str, str], ...], command: str, setting: str,
                 **extra: Any) -> Section:
    """A lanes section at the paper's car counts (4 and 8): the paper's claim, the lanes table,
    figure, statements and learning-curve columns, the paper's budget; ``extra``: other
    :class:`Section` fields (headlines)."""
    return Section(key, title, "lanes", match, LANES_METRICS, LANES_PAPER_CLAIM, command, setting=setting,
                   figure=LANES_FIGURE, statements=lanes_statements("4", paper_counts=True), baseline=LANES_BASELINE,
                   curve_extra=LANES_CURVE_EXTRA, paper_budget=LANES_BUDGET, **extra)


def turn_signals_12_cars(key: str, title: str, match: tuple[tuple[str, str], ...], command: str, setting: str,
                         **extra: Any) -> Section:
    """A turn-signal section at the paper's 12 cars: the paper's claim, the communication table,
    figure and statements, the paper's budget; ``extra``: other :class:`Section` fields (headlines)."""
    return Section(key, title, "real-junction", (("communication", "true"), ("num_cars", "12"), *match),
                   COMMUNICATION_METRICS, COMMUNICATION_CLAIM, command, setting=setting, figure=COMMUNICATION_FIGURE,
                   statements=COMMUNICATION_STATEMENTS, baseline=COMMUNICATION_BASELINE,
                   paper_budget=COMMUNICATION_BUDGET, **extra)


# the right-of-way rules (FIFO order and safe distance at a real junction): columns, the paper's
# claim, numbers and runs, and where the page explains the safe-distance shortfall
RIGHT_OF_WAY_METRICS = (("right_of_way.fifo_share", "FIFO share"),
                        ("safety_distance.safe_share", "safe-distance share"),
                        ("safety_distance.safe_share_moving_leader", "safe-distance share, moving leaders"),
                        ("success_rate", "success"), ("collision_rate", "collisions"))
RIGHT_OF_WAY_CLAIM = ("Cars leave the junction in the order they entered 85.25 +- 8.9 % of the time; 98.45 % of "
                      "following samples keep the speed-matching distance (human drivers in nuScenes: 99.56 %).")
RIGHT_OF_WAY_PAPER = (PaperValue("right_of_way.fifo_share", 0.8525, 0.089, "85.25 +- 8.9 %"),
                      PaperValue("safety_distance.safe_share", 0.9845, None, "98.45 %"),
                      PaperValue("safety_distance.safe_share_moving_leader", 0.9845, None, "98.45 %"))
# the right-of-way measures set beside the scripted drivers (light-blind full throttle, random)
RIGHT_OF_WAY_BASELINE_STATEMENT = scripted_baseline_statement(
    (("right_of_way.fifo_share", "FIFO share"), ("safety_distance.safe_share", "safe-distance share"),
     ("safety_distance.safe_share_moving_leader", "safe-distance share, moving leaders")))
SAFE_SHORTFALL_WORDS = ("Why the safe-distance share falls short of 98.45 % (most unsafe samples are cars closing on a "
                        "wreck, which stays on the road here), and the share under other readings of the paper's "
                        "definition: [real_junctions.md](real_junctions.md#why-the-safe-distance-share-falls-short-"
                        "of-the-paper).")


def right_of_way(key: str, title: str, match: tuple[tuple[str, str], ...], command: str, setting: str,
                 **extra: Any) -> Section:
    """A right-of-way section (8 cars at a real junction, no message): the paper's claim and
    numbers, the table, the FIFO bars beside the gap-against-closing-speed histogram, the
    paper's budget; ``extra``: other :class:`Section` fields (shipped policy, headlines)."""
    return Section(key, title, "real-junction", (("communication", "false"), *match), RIGHT_OF_WAY_METRICS,
                   RIGHT_OF_WAY_CLAIM, command, setting=setting, paper_values=RIGHT_OF_WAY_PAPER,
                   baseline=right_of_way_baselines, statements=(RIGHT_OF_WAY_BASELINE_STATEMENT,),
                   figure=gap_figure(bars_figure("right_of_way.fifo_share", "FIFO share")),
                   paper_budget="8 cars, all junctions, entropy 1e-4, 1,000 epochs of 32,000 joint steps (32 M joint "
                                "steps: up to 256 M car-decisions, fewer as arrived cars leave)", **extra)
