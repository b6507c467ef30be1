"""What a results-page row ran differently from the paper's own command for its claim: the
entropy coefficient, the collision reward, where training started, the world and maps, and the
LiDAR encoder, read from the trial settings the row's sweep command builds (so the list cannot
drift from what ran) against the paper's command as the paper and its code's experiment list
state it. The budget has its own words in the claims table (epochs of joint steps and our share).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

__all__ = ["PaperCommand", "TrialSettings", "deviations", "section_settings"]


@dataclass(frozen=True)
class PaperCommand:
    """The settings of the paper's run for one claim, where the paper (its reward: +1 at the
    goal, -1 for a collision) or its code's experiment list (``--entropy-coeff``,
    ``--model-checkpoint``) gives them. ``start``: where training began, None where neither says."""

    entropy: float
    start: Optional[str] = "from scratch"
    collision_reward: float = -1.0
    # the junctions it drove, where they are not the paper's own simulated ones
    maps: Optional[str] = None


@dataclass(frozen=True)
class TrialSettings:
    """What a sweep's trials ran with (the first trial's; a grid varies none of these)."""

    env_id: str
    entropy: float
    collision_reward: float
    init_from: Optional[str]
    preset: Optional[str]
    lidar_encoder: Optional[str]
    # how cars move ("euler": the paper's code's steps; "exact": ours) and what the critic learns
    # ("rewards_to_go": the paper's code's; "lambda_returns": SB3's)
    integration: Optional[str] = None
    value_targets: Optional[str] = None


# the worlds of the paper's own code, as presets; real junctions and the spline junction have none
PAPER_PRESETS = ("paper", "paper-turns")
# the junctions of `real-junction-v0`, which the paper ran on nuScenes junctions
OUR_MAPS = {"real-junction-v0": "Helsinki junctions from OpenStreetMap"}


def section_settings(key: str) -> TrialSettings:
    """The settings the first trial of section ``key``'s sweep command builds (the command's own
    ``init_from`` string, as the page shows it; the env's default collision reward where the
    command sets none)."""
    from box2d_driving.scenarios import scenario
    from training.results.sections import section
    from training.sweeps.spec import script_module, trial_options

    spec, _ = section(key).spec()
    env_id = script_module(spec.behaviour).ENV_ID
    flat = trial_options(spec, spec.trials()[0])
    env = flat.env_overrides or {}
    default = scenario(env_id).env_class().config_class().collision_reward
    return TrialSettings(env_id, float(flat.ent_coef), float(env.get("collision_reward", default)),
                         spec.fixed.get("init_from") or spec.grid.get("init_from", [None])[0],
                         getattr(flat, "preset", None), getattr(flat, "lidar_encoder", None),
                         env.get("integration"), getattr(flat, "value_targets", None))


def deviations(ours: TrialSettings, paper: PaperCommand) -> list[str]:
    """Each way ``ours`` differs from ``paper``, in words, with the paper's value beside ours."""
    found = []
    if ours.preset not in PAPER_PRESETS:
        found.append("our world and update, not the paper's code's (arrived cars leave, several passes over each "
                     "update's data: [what differs](paper_world.md#the-differences))")
    else:  # the preset's runs from before it took these from the paper's code pin ours
        if ours.integration == "exact":
            found.append("cars moved by exact integration (the paper's code: Euler steps at each 0.1 s step's "
                         "starting speed)")
        if ours.value_targets == "lambda_returns":
            found.append("a critic trained on lambda-returns (the paper's code: discounted rewards-to-go)")
    if ours.env_id in OUR_MAPS and paper.maps:
        found.append(f"{OUR_MAPS[ours.env_id]} (the paper's: {paper.maps})")
    if ours.entropy != paper.entropy:
        found.append(f"entropy {_number(ours.entropy)} (the paper's {_number(paper.entropy)})")
    if ours.collision_reward != paper.collision_reward:
        found.append(f"collision reward {ours.collision_reward:g} (the paper's {paper.collision_reward:g})")
    ran = f"from `{ours.init_from}`" if ours.init_from else "from scratch"
    if ran != (paper.start or "not stated"):
        found.append(f"starts {ran} (the paper's: {paper.start or 'not stated'})")
    if ours.lidar_encoder not in (None, "original"):
        found.append(f"our LiDAR encoder (`lidar_encoder={ours.lidar_encoder}`; the paper's code's: two linear "
                     "strided convolutions)")
    return found


def _number(x: float) -> str:
    """A coefficient as the page writes it: 0.01, 1e-4."""
    return f"{x:g}" if x == 0 or abs(x) >= 0.01 else f"{x:.0e}".replace("e-0", "e-")
