"""Bilevel PPO (the paper's Algorithm 1): alternate the spline sub-policy (one-step bandit) and
the acceleration sub-policy (CTDE PPO) on a spline scenario.

Each round: (1) ``spline_updates_per_round`` times, collect ``spline_samples`` car samples on
:class:`SplineBanditVecEnv` with the acceleration policy greedy and make one single-step PPO
update of the spline policy; (2) collect ``accel_updates_per_round * batch_decisions``
slot-decisions on the :class:`SlotVecEnv` (in the learner's process or ``--num-cpus`` workers)
with the spline policy greedy (each env's ``spline_policy`` is a
:class:`~training.ppo.shared_policy.SharedSplinePicker`, whose shared weights are refreshed after
every spline update), as many PPO updates of the acceleration policy and its centralised critic.
The bandit calls the live acceleration policy, so the frozen side is always the latest one; the
bandit's envs step in the learner's process. Learning rates and clip ranges are constants: SB3
restarts its progress schedule at every ``learn(reset_num_timesteps=False)`` call, which would
otherwise reset annealed values each round. No observation normalisation is used.

Output folder::

    OUT/config.json       the BilevelConfig (written once)
    OUT/accel/            acceleration policy: config.json, model.safetensors, progress.csv, tb/
                          (a normal run folder: load_policy(OUT/accel) works)
    OUT/spline/           spline policy: model.safetensors, progress.csv
    OUT/rounds.csv        one row per round: bandit return, lane side shares, driving outcomes
    OUT/state.json        rounds done, wall-clock seconds, acceleration-stage agent-steps
    OUT/checkpoints/      round_<r>_{accel,spline}.safetensors every ``checkpoint_every`` rounds
"""

from __future__ import annotations

import csv
import json
import math
import os
import shutil
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Optional

import numpy as np
import torch as th
from stable_baselines3 import PPO
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.logger import configure

import box2d_driving
from box2d_driving.config import ConfigError
from box2d_driving.fields import check_bounds, coerce_fields
from box2d_driving.outputs import GracefulStop
from training.ppo.bandit import SplineBanditVecEnv
from training.runs.checkpoint import FILE, CheckpointError, read_checkpoint, restore_model, save_model
from training.runs.inference import actor_actions
from training.common.seeds import check_training_seeds
from training.ppo.shared_policy import SharedSplinePicker
from training.runs.lock import locked_run
from training.runs.resume import truncate_csv
from training.runs.run_dir import (RunError, append_logger, check_new, check_resumable, check_same_run, write_config,
                                   write_json_atomic)
from training.runs.progress import RolloutMetrics
from training.trainers.trainer import (TrainConfig, build_model, load_weights, make_vec_env,
                              resolve_device, resumed_config, set_minibatching, torch_threads)


@dataclass
class BilevelConfig:
    """Everything one bilevel run needs (saved to ``config.json``).

    Attributes:
        accel: the acceleration stage (env id, env overrides, PPO settings); its ``timesteps``
            and ``checkpoint_every`` are unused (rounds decide).
        rounds: alternation rounds N.
        spline_samples: car samples (one inner episode per car) per spline update.
        spline_updates_per_round: spline PPO updates per round (K1 = this x spline_samples).
        accel_updates_per_round: acceleration PPO updates per round (K2 = this x batch_decisions).
        spline_n_envs: env instances simulated side by side for the bandit.
        spline_learning_rate, spline_epochs, spline_minibatch, spline_ent_coef, spline_clip_range:
            single-step PPO settings.
        spline_hidden: hidden layer sizes of the spline policy (and its baseline).
        normalise_bandit_reward: standardise each step's returns (the paper's normalised reward).
        checkpoint_every: rounds between kept checkpoints.
        max_minutes: stop after this much wall-clock time over all sessions (None: no limit).
        spline_init_from: start the spline policy from this bilevel run's spline weights.
    """

    accel: TrainConfig = field(default_factory=TrainConfig)
    rounds: int = 40
    spline_samples: int = 2048
    spline_updates_per_round: int = 1
    accel_updates_per_round: int = 1
    spline_n_envs: int = 16
    spline_learning_rate: float = 1e-3
    spline_epochs: int = 10
    spline_minibatch: int = 256
    spline_ent_coef: float = 0.0
    spline_clip_range: float = 0.2
    spline_hidden: tuple[int, ...] = (64, 64)
    normalise_bandit_reward: bool = True
    checkpoint_every: int = 10
    max_minutes: Optional[float] = None
    spline_init_from: Optional[str] = None

    def __post_init__(self) -> None:
        self.validate()

    def validate(self) -> None:
        """Kinds and ranges of every field (:class:`ConfigError` naming the first bad one)."""
        if not isinstance(self.accel, TrainConfig):
            raise ConfigError(f"BilevelConfig: accel must be a TrainConfig, got {type(self.accel).__name__}")
        self.accel.validate()
        coerce_fields(self, ConfigError, skip=("accel",))
        check_bounds(self, {
            "rounds": (1, 100_000), "spline_samples": (1, None), "spline_updates_per_round": (1, None),
            "accel_updates_per_round": (1, None), "spline_n_envs": (1, 4096), "spline_learning_rate": (0, None),
            "spline_epochs": (1, 1000), "spline_minibatch": (1, None), "spline_ent_coef": (0, None),
            "spline_clip_range": (0, None), "checkpoint_every": (1, None), "max_minutes": (0, None),
        }, ConfigError, above=("spline_learning_rate", "spline_clip_range"))
        if not self.spline_hidden or not all(1 <= h <= 4096 for h in self.spline_hidden):
            raise ConfigError(f"BilevelConfig: spline_hidden must be 1 or more layer sizes in [1, 4096], "
                              f"got {self.spline_hidden!r}")


ROUND_FIELDS = ("round", "wall_s", "agent_steps", "bandit_return", "bandit_success", "bandit_collision",
                "right_share", "left_share", "accel_success", "accel_collision", "accel_violation")


class BanditStats(BaseCallback):
    """Returns, outcomes and junction lane sides of the bandit samples of one spline update."""

    def _on_rollout_start(self) -> None:
        self.returns: list[float] = []
        self.arrived: list[bool] = []
        self.collided: list[bool] = []
        self.lanes: list[float] = []

    def _on_step(self) -> bool:
        for info in self.locals["infos"]:
            self.returns.append(info["episode_return"])
            self.arrived.append(info["arrived"])
            self.collided.append(info["collided"])
            self.lanes.append(info["junction_lane_position"])
        return True

    def _on_rollout_end(self) -> None:
        lanes = np.array(self.lanes)
        lanes = lanes[np.isfinite(lanes)]
        self.stats = {
            "bandit/return_mean": float(np.mean(self.returns)),
            "bandit/success_rate": float(np.mean(self.arrived)),
            "bandit/collision_rate": float(np.mean(self.collided)),
            "bandit/right_share": float(np.mean(lanes > 0)) if len(lanes) else float("nan"),
            "bandit/left_share": float(np.mean(lanes < 0)) if len(lanes) else float("nan"),
        }
        for k, v in self.stats.items():
            self.logger.record(k, v)


def settle_round(out: Path) -> str:
    """Finish or undo a round a kill interrupted: with ``state.json.next`` written (the commit
    point) the ``.next`` files are renamed into place (``"rolled forward"``), state last; without
    it they are removed (``"rolled back"``). ``""`` where there was nothing to settle."""
    pending = [out / f"{name}.next" for name in ROUND_FILES]
    if (out / "state.json.next").exists():
        for path in pending:
            if path.exists():
                os.replace(path, path.with_name(path.name[: -len(".next")]))
        return "rolled forward"
    found = [path for path in pending if path.exists()]
    for path in found:
        path.unlink()
    return "rolled back" if found else ""


def prepare_run_dir(out: Path, resume: bool, config: BilevelConfig) -> None:
    """Check ``out``: with ``resume``, a bilevel run of the same acceleration settings (a round a
    kill interrupted is settled first: :func:`settle_round`); else new or empty."""
    if resume:
        settled = settle_round(out) if out.is_dir() else ""
        if settled:
            print(f"{out}: the round a stop interrupted was {settled}", file=sys.stderr)
        check_resumable(out, ("config.json", "state.json", f"accel/{FILE}", f"spline/{FILE}"))
        check_same_run(json.loads((out / "config.json").read_text())["accel"], config.accel)
        return
    check_new(out)


def start_run_dir(out: Path, config: BilevelConfig) -> None:
    """Create a new run's folders and configs (after every check has passed)."""
    (out / "accel").mkdir(parents=True, exist_ok=True)
    (out / "spline").mkdir(exist_ok=True)
    write_config(out / "config.json", config, "bilevel-ppo")
    write_config(out / "accel" / "config.json", config.accel, "ppo")  # the acceleration stage alone


def make_bandit(config: BilevelConfig, accel_model: PPO) -> SplineBanditVecEnv:
    """The spline stage as a one-step vectorised env whose inner episodes the live acceleration
    policy drives greedily."""
    acfg = config.accel

    def factory():
        return box2d_driving.make(acfg.env_id, **acfg.env_overrides)

    def accel_policy(obs: np.ndarray) -> np.ndarray:
        return actor_actions(accel_model.policy, obs, deterministic=True)

    return SplineBanditVecEnv([factory] * config.spline_n_envs, accel_policy,
                              normalise=config.normalise_bandit_reward)


def build_spline_model(config: BilevelConfig, bandit: SplineBanditVecEnv) -> PPO:
    """PPO for the spline policy on ``bandit``: one-step episodes, so no discounting or GAE
    (``gamma = gae_lambda = 0``)."""
    n_steps = max(1, math.ceil(config.spline_samples / bandit.num_envs))
    return PPO(
        "MlpPolicy", bandit, n_steps=n_steps, batch_size=min(config.spline_minibatch, n_steps * bandit.num_envs),
        n_epochs=config.spline_epochs, learning_rate=config.spline_learning_rate, gamma=0.0,
        gae_lambda=0.0, clip_range=config.spline_clip_range, ent_coef=config.spline_ent_coef,
        policy_kwargs={"net_arch": list(config.spline_hidden)}, seed=config.accel.seed + 1,
        device=resolve_device(config.accel.device), verbose=0,
    )


def make_picker(config: BilevelConfig) -> SharedSplinePicker:
    """The acceleration stage's path picker (greedy spline policy), shared with env workers."""
    acfg = config.accel
    env = box2d_driving.make(acfg.env_id, **acfg.env_overrides)
    try:
        return SharedSplinePicker(env.spline_observation_space, env.spline_action_space, config.spline_hidden)
    finally:
        env.close()


# a round's three files, written as ``NAME.next`` first (see save_round)
ROUND_FILES = (f"accel/{FILE}", f"spline/{FILE}", "state.json")


def save_round(out: Path, accel: PPO, spline: PPO, state: dict, keep: bool) -> None:
    """Both policies and the run's state after a round, as one transaction: each is written as
    ``NAME.next``, ``state.json.next`` last (the commit point), then all three are renamed into
    place (:func:`settle_round`), so that a kill anywhere leaves either the previous round or this
    one, never one policy of each. With ``keep``, a copy of both weights under ``checkpoints/``
    for the learning curve."""
    save_model(accel, out / f"accel/{FILE}.next")
    save_model(spline, out / f"spline/{FILE}.next")
    write_json_atomic(out / "state.json.next", state)
    settle_round(out)
    if keep:
        ck = out / "checkpoints"
        ck.mkdir(exist_ok=True)
        for stage in ("accel", "spline"):
            shutil.copyfile(out / stage / FILE, ck / f"round_{state['round']:04d}_{stage}.safetensors")


def train_bilevel(config: BilevelConfig, out: Path, resume: bool = False,
                  on_checkpoint: Optional[Callable[[dict], None]] = None) -> dict[str, Any]:
    """Run (or continue) the alternation in ``out``; returns the last round's row.
    ``on_checkpoint(row)`` is called after every round is saved. The folder is locked while it
    trains; a disk that refuses a write ends the run with one :class:`RunError`."""
    out = Path(out)
    config.validate()
    with locked_run(out):  # one trainer per folder; a refused write is one line (training/runs/lock.py)
        return _train_bilevel_locked(config, out, resume, on_checkpoint)


def _train_bilevel_locked(config: BilevelConfig, out: Path, resume: bool,
                          on_checkpoint: Optional[Callable[[dict], None]]) -> dict[str, Any]:
    from tqdm import tqdm

    prepare_run_dir(out, resume, config)
    acfg = config.accel
    th.set_num_threads(torch_threads(acfg))
    picker = make_picker(config)  # every acceleration-stage episode's paths, greedily
    accel_venv = make_vec_env(acfg, spline_policy=picker)
    if resume:
        state = json.loads((out / "state.json").read_text())
        # rounds a kill left logged but not saved are logged again by this leg: cut them here
        truncate_csv(out / "rounds.csv", "round", state["round"])
        accel, bandit, spline = _resume_models(config, out, accel_venv)
    else:
        state = {"round": 0, "wall_s": 0.0, "agent_steps": 0}
        accel, bandit, spline = _new_models(config, out, accel_venv)
    set_minibatching(accel, acfg, accel_venv.n_cars)
    # each round's seeds follow from the round it starts at, so a resumed run goes on as it would have
    accel_venv.seed(acfg.seed + 1000 * state["round"])
    bandit_seed = acfg.seed + 10**6 + 1000 * state["round"]
    check_training_seeds(bandit_seed, bandit.num_envs)
    bandit.seed(bandit_seed)
    picker.load(spline.policy)

    max_seconds = math.inf if config.max_minutes is None else 60.0 * config.max_minutes
    rounds_csv = out / "rounds.csv"
    new_file = not rounds_csv.exists()
    row: dict[str, Any] = {}
    bar = tqdm(total=config.rounds, initial=state["round"], unit="round", dynamic_ncols=True)
    stop = GracefulStop()  # Ctrl-C / SIGTERM: the acceleration updates of this round end early,
    # the round is saved, and the loop ends (a second signal stops at once)
    with stop.installed(), rounds_csv.open("a", newline="") as fh:
        writer = csv.DictWriter(fh, fieldnames=ROUND_FIELDS)
        if new_file:
            writer.writeheader()
        while state["round"] < config.rounds and state["wall_s"] < max_seconds and not stop.requested:
            state, row = _one_round(config, out, accel, accel_venv, spline, bandit, picker, state, max_seconds, stop)
            writer.writerow(row)
            fh.flush()
            save_round(out, accel, spline, state, keep=state["round"] % config.checkpoint_every == 0)
            if on_checkpoint is not None:
                on_checkpoint(dict(row))
            bar.update(1)
            bar.set_postfix(ret=f"{row['bandit_return']:.2f}", right=f"{row['right_share']:.2f}",
                            success=f"{row['accel_success']:.2f}", refresh=False)
    bar.close()
    accel_venv.close()
    bandit.close()
    if stop.requested:
        row = {**row, "interrupted_by_signal": stop.signum}
    return row


def _new_models(config: BilevelConfig, out: Path, accel_venv: Any) -> tuple[PPO, SplineBanditVecEnv, PPO]:
    """The acceleration model, the spline bandit and the spline model of a new run in ``out``
    (from ``init_from`` / ``spline_init_from`` weights where given), with their loggers."""
    acfg = config.accel
    accel = build_model(acfg, accel_venv)
    if acfg.init_from:
        load_weights(accel, Path(acfg.init_from))
    bandit = make_bandit(config, accel)
    spline = build_spline_model(config, bandit)
    if config.spline_init_from:
        src = Path(config.spline_init_from)
        src = src / "spline" if (src / "spline").is_dir() else src
        try:
            restore_model(spline, read_checkpoint(src), optimizer=False)
        except CheckpointError as exc:
            raise RunError(f"--spline-init-from: {exc}") from None
        spline.num_timesteps = spline._n_updates = 0
    start_run_dir(out, config)
    accel.set_logger(configure(str(out / "accel"), ["csv", "tensorboard"]))
    spline.set_logger(configure(str(out / "spline"), ["csv"]))
    return accel, bandit, spline


def _resume_models(config: BilevelConfig, out: Path, accel_venv: Any) -> tuple[PPO, SplineBanditVecEnv, PPO]:
    """The three of :func:`_new_models` as the run in ``out`` last saved them (weights, optimiser
    state, step counts), their logs continued."""
    accel = build_model(resumed_config(out / "accel", config.accel), accel_venv)
    bandit = make_bandit(config, accel)
    spline = build_spline_model(config, bandit)
    try:
        restore_model(accel, read_checkpoint(out / "accel"))
        restore_model(spline, read_checkpoint(out / "spline"))
    except CheckpointError as exc:
        raise RunError(f"--resume: {exc}") from None
    accel.set_logger(append_logger(out / "accel", accel.num_timesteps))
    spline.set_logger(append_logger(out / "spline", spline.num_timesteps))
    return accel, bandit, spline


def _one_round(config: BilevelConfig, out: Path, accel: PPO, accel_venv: Any, spline: PPO,
               bandit: SplineBanditVecEnv, picker: SharedSplinePicker, state: dict, max_seconds: float,
               stop: GracefulStop) -> tuple[dict, dict[str, Any]]:
    """One round: the spline updates, then the acceleration updates on the paths they pick;
    returns the run's new state and the round's row of ``rounds.csv``."""
    t0 = time.perf_counter()
    stats = BanditStats()
    spline.learn(config.spline_updates_per_round * spline.n_steps * bandit.num_envs,
                 callback=stats, reset_num_timesteps=False)
    picker.load(spline.policy)  # the acceleration stage drives the latest paths
    metrics = RolloutMetrics(out / "accel", math.inf, state["wall_s"], state["agent_steps"],
                             checkpoint_every=10**9, max_seconds=max_seconds, show_bar=False, stop=stop)
    accel.learn(config.accel_updates_per_round * accel.n_steps * accel_venv.num_envs,
                callback=metrics, reset_num_timesteps=False)
    state = {"round": state["round"] + 1, "wall_s": state["wall_s"] + time.perf_counter() - t0,
             "agent_steps": metrics.agent_steps,
             "accel_decisions": accel.num_timesteps, "spline_samples": spline.num_timesteps}
    a = getattr(metrics, "last_stats", {})
    b = stats.stats
    row = {"round": state["round"], "wall_s": round(state["wall_s"], 1),
           "agent_steps": state["agent_steps"], "bandit_return": b["bandit/return_mean"],
           "bandit_success": b["bandit/success_rate"], "bandit_collision": b["bandit/collision_rate"],
           "right_share": b["bandit/right_share"], "left_share": b["bandit/left_share"],
           "accel_success": a.get("rollout/success_rate", float("nan")),
           "accel_collision": a.get("rollout/collision_rate", float("nan")),
           "accel_violation": a.get("rollout/red_light_violation_rate", float("nan"))}
    return state, row
