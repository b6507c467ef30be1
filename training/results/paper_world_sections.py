"""The results page's sections in the paper's own world and update (``--preset paper``): the
4-car noise grid and its noise-1.0 sweep in the preset as it is now (on the left, reading the
sat-nav as the paper's code does); then the runs made in its earlier mirror image: the same grid,
a lone car and 8 cars with the paper code's LiDAR encoder, and the preset's first runs with ours
(kept apart: most of their actors were blind). Part of
:data:`training.results.sections.SECTIONS`, in page order."""

from __future__ import annotations

import dataclasses

from training.original.commands import TrainerSettings
from training.results.baselines import lights_baselines
from training.results.figures import bars_figure
from training.results.page_section import Headline, Section
from training.results.rule_parts import (DENSER_BUDGET, DENSER_JOINT_STEPS, LIGHTS_BASELINE_STATEMENT, LIGHTS_METRICS,
                                         LIGHTS_NOISE_BUDGET, LIGHTS_NOISE_FIGURE, LIGHTS_NOISE_JOINT_STEPS,
                                         LIGHTS_NOISE_STATEMENTS, SWEEP)
from training.results.statements import lone_car_statement

__all__ = ["LEFT_8CARS_FROM", "PAPER_WORLD_LIGHTS", "PRESET_8CARS_FROM"]

# the 8-car preset rules' starting policies: a kept trial of the 4-car grid in the same world (its
# actor alone)
PRESET_8CARS_FROM = "assets/sweeps/weights/lights-paper-net/lights_lidar_noise=0.5_seed=0"
LEFT_8CARS_FROM = "assets/sweeps/weights/lights-paper-left/lights_lidar_noise=0.5_seed=0"
NOISE1_BUDGET = "4 cars at LiDAR noise 1.0 for 50 epochs of 32,000 joint steps (1.6 M joint steps), entropy 1e-4"
LONE_CAR_CLAIM = ("In a single agent environment there is no need to follow the signals (the paper's figure "
                  "caption); its experiment list says of its 1-car run that the actions are not correlated with "
                  "the signals.")
LONE_CAR_SETTING = ("Each trial trains one car alone in the world and update of the 4-car section, at its LiDAR "
                    "noise 0.25 and for its 75 epochs of 32,000 joint steps (2.4 M decisions of the one car): only "
                    "the number of cars differs, so that section's noise-0.25 row is the 4-car comparison. The "
                    "original's own 1-car run differed in more: turning tracks on a junction of 12 signals with "
                    "right-of-way lights (`turns`, `learn_right_of_way`), a horizon of 20 decisions, entropy "
                    "1e-3, LiDAR noise 0, 60 epochs: [A lone car in the paper's own turning world]"
                    "(#a-lone-car-in-the-papers-own-turning-world) runs that. Six seeds were planned before any "
                    "was run.")
LONE_CAR_TURNS_SETTING = ("Each trial trains one car alone in the paper's own turning junction, as the original's "
                          "1-car run has it (`preset=paper-turns`: each car's exit drawn among the three other "
                          "roads, the paper's code's turning motion, two merged phases of lights that start green "
                          "for approaches 0 and 2 one time in eight, a horizon of 20 decisions; and the `paper` "
                          "preset's world, update and network as they are now, Euler steps and a critic trained "
                          "on discounted rewards included; what each is: [paper_world.md](paper_world.md"
                          "#the-lone-car-turning-world)), with the original command's settings: LiDAR noise 0, "
                          "entropy 1e-3, 60 epochs of 32,000 joint steps (1.92 M decisions of the one car), from "
                          "scratch. Six seeds were planned before any was run.")
LONE_CAR_BUDGET = ("1 car for 60 epochs of 32,000 joint steps (1.92 M), with turns and right-of-way lights, horizon "
                   "20 decisions, entropy 1e-3, LiDAR noise 0")
DENSER_SETTING = ("Each trial fine-tunes, with 8 cars, one 4-car policy of the grid above (its noise-0.5 trial of "
                  "seed 0) in the paper's world, update and network at LiDAR noise 0.5, each car's arm drawn at "
                  "random (the original's `balance_cars: false` for its 8-car run), for 75 epochs of 32,000 joint "
                  "steps: 2.4 M joint steps, 19.2 M car-decisions, 15 % of the original's 500 epochs. Deviations "
                  "from the original command: it fine-tuned actor and critic of its 4-car noise-0 model; the grid "
                  "keeps actors alone, so our critic starts fresh, and the grid has no noise-0 row, so the "
                  "starting policy and the comparison row are both the grid's noise 0.5. Four seeds were planned "
                  "before any was run.")
# the 4-car noise grid and its noise-1.0 sweep, in whichever world they ran
GRID_SETTING = ("Each trial trains 4 cars from scratch with our trainer in the paper's own world, update and network "
                "(`--preset paper`: an arrived car stays until the horizon of 25 decisions, every car decides at "
                "every step, one pass over each epoch in 20 minibatches, entropy 1e-4, the paper's KL rule, and "
                "the LiDAR encoder of the paper's code, two linear strided convolutions; what each setting is: "
                "[paper_world.md](paper_world.md)) for the paper's own budget: 75 epochs of 32,000 joint steps at "
                "noise 0.25, 0.5 and 0.75, and, from the sweep joined below it, 50 epochs at noise 1.0, as the "
                "original commands list them. The same training seeds run at every noise level, so the noise "
                "trend is tested paired by seed. Six seeds at every level were planned before any was run.")
NOISE1_SETTING = ("The section above at LiDAR noise 1.0 (every ray dropped: the cars see no other car), for the "
                  "original command's 50 epochs of 32,000 joint steps; its trials join the section above as its "
                  "noise-1.0 row, paired by seed with the other levels.")
# the preset since 2026-12-06: the paper's code's side of the road and its sat-nav readings, with
# our exact motion and SB3's value targets (pinned: the preset now steps and trains its critic as
# the paper's code does, integration=euler, value_targets=rewards_to_go)
PAPER_CODE_SETTINGS = (("drive_on", "left"), ("arrived_heading_error", "minus_heading"),
                       ("goal_distance", "straight"), ("light_view", "axis_point"), ("integration", "exact"),
                       ("value_targets", "lambda_returns"))
PAPER_NOW = ("preset=paper drive_on=left arrived_heading_error=minus_heading goal_distance=straight "
             "light_view=axis_point integration=exact value_targets=lambda_returns")
PAPER_CODE_NOTE = ("In the paper's world as its code has it (the preset since 2026-12-06): every car left of its "
                   "road's axis, its light seen within 30 m in a straight line of its arm's axis at the junction, "
                   "its goal distance read in a straight line to the goal on the road axis, and once arrived, for "
                   "good, minus its heading as its heading error (due west -pi) and 1 as its goal "
                   "distance; cars moved by our exact integration (`integration=exact`, pinned in the command), "
                   "where the preset now steps as the paper's code does, at each 0.1 s step's starting speed "
                   "(`integration=euler`; [paper_world.md](paper_world.md#motion-integration)); and a critic "
                   "trained on SB3's lambda-returns (`value_targets=lambda_returns`, pinned), where the preset "
                   "now trains it on discounted rewards as the paper's code does. The paper's own "
                   "trainer's policies drive this world as they drive theirs, and "
                   "policies of ours drive the paper's world as they drive this one "
                   "([paper_world.md](paper_world.md#policies-in-both-worlds)).")
# the world (and value targets) every section here ran with: the preset as it stood before
# 2026-12-06, on the right, reading an arrived car's heading error as 0 and the goal distance
# along the track (training/sweeps/spec.py, PINNED)
MIRROR_SETTINGS = (("drive_on", "right"), ("arrived_heading_error", "zero"), ("goal_distance", "path"),
                   ("light_view", "stop_line"), ("integration", "exact"), ("value_targets", "lambda_returns"))
# the same, in a sweep command
PAPER_BEFORE = ("preset=paper drive_on=right arrived_heading_error=zero goal_distance=path light_view=stop_line "
                "integration=exact value_targets=lambda_returns")
MIRROR_NOTE = ("Run before the preset drove on the left as the paper's code does (`drive_on=right`, pinned in the "
               "command): the mirror image of the paper's world, which no scripted driver's statistics tell apart, "
               "and with an arrived car's heading error 0 where the paper's code reads minus its heading "
               "(`arrived_heading_error=zero`), and the distance to the goal read along the track where the "
               "paper's code reads it in a straight line to the goal on the road axis (`goal_distance=path`), "
               "and a car seeing its light within 30 m before its stop line along the approach where the "
               "paper's code measures a straight line to its arm's axis at the junction (`light_view=stop_line`). "
               "These policies drive the paper's own world differently: their red entries there follow those "
               "on the left of ours, seed by seed, and they crash more after arriving (the paper's own "
               "policies drive both worlds alike: [paper_world.md](paper_world.md#policies-in-both-worlds)).")
# why the preset's first runs stand apart (docs/paper_world.md, "The LiDAR encoder")
RELU_NOTE = ("Run before the preset had the paper code's LiDAR encoder, with ours (`lidar_encoder=relu`: its last "
             "ReLU sits on a single channel). In most of these actors that ReLU is dead: their LiDAR features are "
             "the same for every observation, so they drive by the light and their own speed alone, blind to "
             "the other cars (`box2d-driving lidar-use` measures it; the table in "
             "[paper_world.md](paper_world.md#the-lidar-encoder)). A blind actor cannot test a claim about "
             "LiDAR noise.")


def _noise_grid(key: str, title: str, title_noise1: str, world: tuple[tuple[str, str], ...], world_command: str,
                encoder: str, out: str, setting: str, setting_noise1: str,
                headlines: tuple[Headline, ...] = ()) -> tuple[Section, Section]:
    """The 4-car noise grid (LiDAR noise 0.25, 0.5, 0.75; 75 epochs) in the paper's update with the
    LiDAR ``encoder`` (``lidar_encoder``), in ``world`` (its options; ``world_command`` the same
    in a sweep command), and its noise-1.0 sweep (50 epochs, the original command's), which joins
    the grid's table as its noise-1.0 row; sweep folders ``runs/OUT`` and ``runs/OUT-noise1``."""
    fixed = (("init_from", "false"), ("num_cars", "4"), ("preset", "paper"), *world)
    grid = Section(
        key, title, "lights", (*fixed, ("lidar_encoder", encoder)), LIGHTS_METRICS,
        "With more LiDAR noise, fewer cars enter on red (the paper's 4-car runs at noise 0.25 to 1.0).",
        f"{SWEEP} lights --grid lidar_noise=0.25,0.5,0.75 --seeds 6 --set num_cars=4 {world_command} "
        f"lidar_encoder={encoder} original_epochs=75 --out runs/{out}",
        setting=setting, figure=LIGHTS_NOISE_FIGURE, baseline=lights_baselines, statements=LIGHTS_NOISE_STATEMENTS,
        paper_budget=LIGHTS_NOISE_BUDGET, paper_joint_steps=LIGHTS_NOISE_JOINT_STEPS, cars=4,
        joins=(f"{key}-noise1", "lidar_noise"), joins_differ=("original_epochs",), headlines=headlines)
    noise1 = Section(
        f"{key}-noise1", title_noise1, "lights", (*fixed, ("lidar_noise", "1.0"), ("lidar_encoder", encoder)),
        LIGHTS_METRICS,
        "With more LiDAR noise, fewer cars enter on red (the paper's 4-car run at noise 1.0 trained 50 epochs).",
        f"{SWEEP} lights --seeds 6 --set num_cars=4 lidar_noise=1.0 {world_command} lidar_encoder={encoder} "
        f"original_epochs=50 --out runs/{out}-noise1",
        setting=setting_noise1, baseline=lights_baselines, statements=(LIGHTS_BASELINE_STATEMENT,),
        paper_budget=NOISE1_BUDGET, paper_joint_steps=50 * TrainerSettings.steps_per_epoch, cars=4)
    return grid, noise1


# the noise grid in the preset on the left (its sections first on the page), a lone car and 8 cars
# in the same world
_PAPER_CODE_LIGHTS: tuple[Section, ...] = (
    *_noise_grid(
        "traffic-lights-paper-left", "Stopping at red lights in the paper's own world, update and network (on the "
        "left)", "Stopping at red lights in the paper's own world, update and network (on the left), LiDAR noise 1.0",
        PAPER_CODE_SETTINGS, PAPER_NOW, "original", "sweep-lights-paper-left",
        f"{GRID_SETTING} {PAPER_CODE_NOTE}", f"{NOISE1_SETTING} {PAPER_CODE_NOTE}",
        headlines=(Headline("stop at red lights, the paper's world, update, network and budget",
                            "`intersection-v0` with `preset=\"paper\"`, 4 cars, LiDAR noise 0.5, 75 epochs of "
                            "32,000 joint steps (9.6 M decisions, the paper's own run)",
                            (("lidar_noise", "0.5"),),
                            ("red_light_violation_rate", "success_rate", "collision_rate"), in_readme=True),)),
    Section("traffic-lights-paper-turns-1car", "A lone car in the paper's own turning world", "lights",
            (("init_from", "false"), ("num_cars", "1"), ("preset", "paper-turns"), ("lidar_noise", "0.0"),
             ("lidar_encoder", "original")),
            LIGHTS_METRICS, LONE_CAR_CLAIM,
            f"{SWEEP} lights --seeds 6 --set num_cars=1 lidar_noise=0.0 preset=paper-turns lidar_encoder=original "
            "original_epochs=60 --out runs/sweep-lights-paper-turns-1car",
            setting=LONE_CAR_TURNS_SETTING, baseline=lights_baselines, statements=(lone_car_statement,),
            paper_budget=LONE_CAR_BUDGET, paper_joint_steps=60 * TrainerSettings.steps_per_epoch, cars=1),
    Section("traffic-lights-paper-left-1car", "A lone car in the paper's own world, update and network (on the left)",
            "lights",
            (("init_from", "false"), ("num_cars", "1"), ("preset", "paper"), *PAPER_CODE_SETTINGS,
             ("lidar_encoder", "original")),
            LIGHTS_METRICS, LONE_CAR_CLAIM,
            f"{SWEEP} lights --seeds 6 --set num_cars=1 lidar_noise=0.25 {PAPER_NOW} lidar_encoder=original "
            "original_epochs=75 --out runs/sweep-lights-paper-left-1car",
            setting=f"{LONE_CAR_SETTING} {PAPER_CODE_NOTE}",
            baseline=lights_baselines, statements=(lone_car_statement,),
            compare_with=("traffic-lights-paper-left", (("lidar_noise", "0.25"),)),
            paper_budget=LONE_CAR_BUDGET, paper_joint_steps=60 * TrainerSettings.steps_per_epoch, cars=1),
    Section("traffic-lights-paper-left-8cars", "Denser traffic in the paper's own world, update and network (on the "
            "left, 8 cars)", "lights",
            (("num_cars", "8"), ("preset", "paper"), *PAPER_CODE_SETTINGS, ("approach_order", "random"),
             ("lidar_encoder", "original")),
            LIGHTS_METRICS,
            "With more cars, fewer cars enter on red (the paper's 8-car run, fine-tuned from its 4-car policy).",
            f"{SWEEP} lights --seeds 4 --set num_cars=8 lidar_noise=0.5 {PAPER_NOW} lidar_encoder=original "
            f"approach_order=random original_epochs=75 init_from={LEFT_8CARS_FROM} "
            "--out runs/sweep-lights-paper-left-8cars",
            setting=f"{DENSER_SETTING} {PAPER_CODE_NOTE}",
            figure=bars_figure("red_light_violation_rate", "red-light violation rate"),
            baseline=lights_baselines, statements=(LIGHTS_BASELINE_STATEMENT,),
            compare_with=("traffic-lights-paper-left", (("lidar_noise", "0.5"),)),
            paper_budget=DENSER_BUDGET, paper_joint_steps=DENSER_JOINT_STEPS, cars=8),
)

# the paper-world lights sections, in page order: the paper code's encoder first, then the preset's first runs
_PAPER_WORLD_LIGHTS: tuple[Section, ...] = (
    *_noise_grid(
        "traffic-lights-preset", "Stopping at red lights in the paper's world, update and network",
        "Stopping at red lights in the paper's world, update and network, LiDAR noise 1.0",
        MIRROR_SETTINGS, PAPER_BEFORE, "original", "sweep-lights-paper-net", GRID_SETTING, NOISE1_SETTING),
    Section("traffic-lights-preset-1car", "A lone car in the paper's world, update and network", "lights",
            (("init_from", "false"), ("num_cars", "1"), ("preset", "paper"), *MIRROR_SETTINGS,
             ("lidar_encoder", "original")),
            LIGHTS_METRICS, LONE_CAR_CLAIM,
            f"{SWEEP} lights --seeds 6 --set num_cars=1 lidar_noise=0.25 {PAPER_BEFORE} lidar_encoder=original "
            "original_epochs=75 --out runs/sweep-lights-paper-net-1car",
            setting=LONE_CAR_SETTING,
            baseline=lights_baselines, statements=(lone_car_statement,),
            compare_with=("traffic-lights-preset", (("lidar_noise", "0.25"),)),
            paper_budget=LONE_CAR_BUDGET, paper_joint_steps=60 * TrainerSettings.steps_per_epoch, cars=1),
    Section("traffic-lights-preset-8cars", "Denser traffic in the paper's world, update and network (8 cars)",
            "lights",
            (("num_cars", "8"), ("preset", "paper"), *MIRROR_SETTINGS,
             ("approach_order", "random"), ("lidar_encoder", "original")),
            LIGHTS_METRICS,
            "With more cars, fewer cars enter on red (the paper's 8-car run, fine-tuned from its 4-car policy).",
            f"{SWEEP} lights --seeds 4 --set num_cars=8 lidar_noise=0.5 {PAPER_BEFORE} lidar_encoder=original "
            f"approach_order=random original_epochs=75 init_from={PRESET_8CARS_FROM} "
            "--out runs/sweep-lights-paper-net-8cars",
            setting=DENSER_SETTING,
            figure=bars_figure("red_light_violation_rate", "red-light violation rate"),
            baseline=lights_baselines, statements=(LIGHTS_BASELINE_STATEMENT,),
            compare_with=("traffic-lights-preset", (("lidar_noise", "0.5"),)),
            paper_budget=DENSER_BUDGET, paper_joint_steps=DENSER_JOINT_STEPS, cars=8),
    # the preset's first runs, before it had the paper code's LiDAR encoder: ours, often dead
    *_noise_grid(
        "traffic-lights-preset-relu", "Stopping at red lights in the paper's world and update, our LiDAR encoder",
        "Stopping at red lights in the paper's world and update, LiDAR noise 1.0, our LiDAR encoder",
        MIRROR_SETTINGS, PAPER_BEFORE, "relu", "sweep-lights-preset",
        f"{RELU_NOTE} Otherwise the section \"Stopping at red lights in the paper's world, update and network\": "
        "4 cars from scratch, `--preset paper`, 75 epochs of 32,000 joint steps at noise 0.25, 0.5 and 0.75 and, "
        "joined below it, 50 at noise 1.0, the same training seeds at every level. Six seeds at every level were "
        "planned; the grid was stopped at 10 of 18 when the dead encoders were found.",
        "The section above at LiDAR noise 1.0 for 50 epochs, with our LiDAR encoder; at noise 1.0 every ray is "
        "dropped, so no encoder can see another car."),
    Section("traffic-lights-preset-relu-1car", "A lone car in the paper's world and update, our LiDAR encoder",
            "lights",
            (("init_from", "false"), ("num_cars", "1"), ("preset", "paper"), *MIRROR_SETTINGS,
             ("lidar_encoder", "relu")),
            LIGHTS_METRICS, LONE_CAR_CLAIM,
            f"{SWEEP} lights --seeds 6 --set num_cars=1 lidar_noise=0.25 {PAPER_BEFORE} lidar_encoder=relu "
            "original_epochs=75 --out runs/sweep-lights-preset-1car",
            setting=f"{RELU_NOTE} A lone car has no other car to see, so its LiDAR matters less here. "
                    + LONE_CAR_SETTING,
            baseline=lights_baselines, statements=(lone_car_statement,),
            compare_with=("traffic-lights-preset-relu", (("lidar_noise", "0.25"),)),
            paper_budget=LONE_CAR_BUDGET, paper_joint_steps=60 * TrainerSettings.steps_per_epoch, cars=1),
)
# the grid in the preset as it is now, then every section run in its earlier world, which each setting says
PAPER_WORLD_LIGHTS: tuple[Section, ...] = (*_PAPER_CODE_LIGHTS,
                                           *(dataclasses.replace(s, setting=f"{s.setting} {MIRROR_NOTE}")
                                             for s in _PAPER_WORLD_LIGHTS))
