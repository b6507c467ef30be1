"""The settings of one training run, :class:`TrainConfig` (saved to a run's ``config.json``),
and the names its choice fields accept."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Optional

from box2d_driving.config import ConfigError
from box2d_driving.fields import check_bounds, coerce_fields
from training.common.seeds import MAX_RUN_SEED
from training.ppo.policy import CRITICS, ENCODERS
from training.ppo.vec_env import TRANSPORTS

DEVICES = ("auto", "cpu", "cuda")
KL_STOPS = ("update", "actor")
ADVANTAGE_NORMALISATIONS = ("minibatch", "per_car")
VALUE_TARGETS = ("lambda_returns", "rewards_to_go")


@dataclass
class TrainConfig:
    """Everything one training run needs (saved to ``config.json``).

    Attributes:
        env_id: registered env id.
        env_overrides: env config overrides (``num_cars``, ``lidar_noise`` ...).
        timesteps: total slot-decisions to train for (one per car slot per env step, padding
            included; agent-steps, which exclude padding, are logged too).
        seed: seeds PPO and the envs.
        n_envs: env instances stepped in one process.
        batch_decisions: slot-decisions collected per PPO update (the paper: 32,000).
        minibatch: minibatch size (real transitions).
        epochs: PPO epochs per update.
        minibatch_by_step: draw minibatches by env step (all live cars of an instance at one step
            together) instead of by single transition, so the centralised critic encodes each
            step's team once instead of once per car (see ``training/ppo/buffer.py``). The default
            since it trained the 4-car lights policy as well per sample, 1.7x faster (docs/benchmarks.md).
        learning_rate, gamma, gae_lambda, clip_range, target_kl: PPO settings (the paper's).
        ent_coef: entropy bonus (a resumed run takes the value given now).
        critic: ``mean`` (one team value, the paper) or ``own+mean``.
        lidar_encoder: the actor's and critic's LiDAR encoder: ``original`` (the paper's code:
            two linear strided convolutions to one channel; the default since 2026-12-06) or
            ``relu`` (ours before: two circular convolutions of 8 channels, kernel 5, ReLU after
            each; runs and shipped policies from before are read as it). Ours can end, or even
            start, with its one-channel ReLU dead, the actor then blind to its LiDAR
            (docs/paper_world.md, "The LiDAR encoder"). A fine-tune (``init_from``) must build
            the encoder of the weights it starts from.
        checkpoint_every: updates between checkpoints.
        threads: torch CPU threads (None: while collecting rollouts the cores the env worker
            processes leave free, during the update every core, as the workers wait then).
        num_cpus: worker processes stepping the env instances (0: all in the learner's process).
            The instances go in runs of ``ceil(n_envs / num_cpus)``, so a number that does not
            divide ``n_envs`` may start fewer (16 instances over 15 workers: 8 processes of 2).
            Rollouts are identical whatever the number, for the same seed and ``n_envs``.
        transport: how worker processes exchange each step with the learner: ``shared`` (every
            per-step array in shared memory, full infos only at a car's end;
            :mod:`training.ppo.shared_workers`) or ``supersuit`` (SuperSuit's ``ProcConcatVec``:
            every car's info pickled each step). Same rollouts either way.
        overlap: with worker processes, the workers step the next decision while the learner
            finishes the values and files the last one (:mod:`training.ppo.overlapped`); same
            rollouts and weights as SB3's loop (False).
        device: where the networks run: ``auto`` (CUDA when torch sees a GPU), ``cpu`` or ``cuda``.
        max_minutes: stop (and checkpoint) once the run's total wall-clock time, across
            ``--resume``, reaches this; None for no limit. For equal-budget comparisons.
        init_from: start from the weights of this checkpoint (e.g. a 4-car policy fine-tuned
            with 8 cars, as the paper does); observation layout and critic must match.
        clip_range_vf: clip the value estimate to this around the rollout's (the paper's code:
            0.2); None: unclipped.
        kl_stop: ``"update"`` (SB3: the whole update ends once the KL exceeds 1.5 x
            ``target_kl``) or ``"actor"`` (the paper's code: only the actor stops, the critic
            trains on; :mod:`training.ppo.original_update`).
        advantage_normalisation: ``"minibatch"`` (SB3) or ``"per_car"`` (over the whole update,
            per car index, the paper's code).
        value_targets: what the critic is trained towards: ``"lambda_returns"`` (SB3: GAE
            advantage + value) or ``"rewards_to_go"`` (the paper's code: discounted rewards,
            bootstrapped only where the rollout cuts an episode).
        adam_eps: Adam's epsilon (SB3: 1e-5; the paper's code: 1e-8).
        max_grad_norm: gradients clipped to this global norm (SB3: 0.5); None: not clipped (the
            paper's code).
        bootstrap_truncation: a time limit is a truncation whose value is bootstrapped (True);
            False treats it as terminal, value 0 (the paper's code).
        preset: the named preset the run was built from (``paper``), recorded for reading; its
            values are already in the other fields.
    """

    env_id: str = "intersection-v0"
    env_overrides: dict = field(default_factory=dict)
    timesteps: int = 3_000_000
    seed: int = 0
    n_envs: int = 16
    batch_decisions: int = 32_000
    minibatch: int = 4_000
    epochs: int = 4
    minibatch_by_step: bool = True
    learning_rate: float = 1e-3
    gamma: float = 0.99
    gae_lambda: float = 0.97
    clip_range: float = 0.2
    target_kl: Optional[float] = 0.2
    ent_coef: float = 0.01
    critic: str = "mean"
    lidar_encoder: str = "original"
    checkpoint_every: int = 10
    threads: Optional[int] = None
    num_cpus: int = 0
    transport: str = "shared"
    overlap: bool = True
    device: str = "auto"
    max_minutes: Optional[float] = None
    init_from: Optional[str] = None
    clip_range_vf: Optional[float] = None
    kl_stop: str = "update"
    advantage_normalisation: str = "minibatch"
    value_targets: str = "lambda_returns"
    adam_eps: float = 1e-5
    max_grad_norm: Optional[float] = 0.5
    bootstrap_truncation: bool = True
    preset: Optional[str] = None

    def __post_init__(self) -> None:
        self.validate()

    def validate(self) -> None:
        """Check every field (kinds, then ranges); :class:`ConfigError` names the first bad one.
        Called on construction and again by :func:`train` (fields may be set in between)."""
        coerce_fields(self, ConfigError, skip=("env_overrides",))
        if not isinstance(self.env_overrides, dict):
            raise ConfigError(f"TrainConfig: env_overrides must be a dict, got {self.env_overrides!r}")
        check_bounds(self, {  # timesteps 0: a bilevel run's acceleration stage (rounds decide)
            "timesteps": (0, 1_000_000_000), "seed": (0, MAX_RUN_SEED), "n_envs": (1, 4096),
            "batch_decisions": (1, None), "minibatch": (1, None),
            "epochs": (1, 1000), "checkpoint_every": (1, None), "threads": (1, 1024), "num_cpus": (0, 1024),
            "learning_rate": (0, None), "gamma": (0, 1), "gae_lambda": (0, 1), "clip_range": (0, None),
            "target_kl": (0, None), "ent_coef": (0, None), "max_minutes": (0, None), "clip_range_vf": (0, None),
            "adam_eps": (0, 1), "max_grad_norm": (0, None),
        }, ConfigError, above=("learning_rate", "clip_range", "target_kl", "clip_range_vf", "adam_eps",
                               "max_grad_norm"))
        if self.kl_stop not in KL_STOPS:
            raise ConfigError(f"TrainConfig: kl_stop must be one of {KL_STOPS}, got {self.kl_stop!r}")
        if self.kl_stop == "actor" and self.target_kl is None:
            raise ConfigError("TrainConfig: kl_stop='actor' needs a target_kl")
        if self.advantage_normalisation not in ADVANTAGE_NORMALISATIONS:
            raise ConfigError(f"TrainConfig: advantage_normalisation must be one of {ADVANTAGE_NORMALISATIONS}, "
                              f"got {self.advantage_normalisation!r}")
        if self.value_targets not in VALUE_TARGETS:
            raise ConfigError(f"TrainConfig: value_targets must be one of {VALUE_TARGETS}, got {self.value_targets!r}")
        if self.transport not in TRANSPORTS:
            raise ConfigError(f"TrainConfig: transport must be one of {TRANSPORTS}, got {self.transport!r}")
        if self.device not in DEVICES:
            raise ConfigError(f"TrainConfig: device must be one of {DEVICES}, got {self.device!r}")
        if self.critic not in CRITICS:
            raise ConfigError(f"TrainConfig: critic must be one of {CRITICS}, got {self.critic!r}")
        if self.lidar_encoder not in ENCODERS:
            raise ConfigError(f"TrainConfig: lidar_encoder must be one of {ENCODERS}, got {self.lidar_encoder!r}")

    def n_steps(self, n_cars: int) -> int:
        return max(1, math.ceil(self.batch_decisions / (self.n_envs * n_cars)))
