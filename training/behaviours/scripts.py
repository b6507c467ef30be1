"""Shared CLI of the training scripts: a dataclass of arguments, turned into a TrainConfig."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, cast

from box2d_driving.config import ConfigError, DrivingConfig
from box2d_driving.presets import preset_overrides
from training.trainers.bilevel import BilevelConfig
from training.trainers.presets import training_preset
from training.trainers.trainer import TrainConfig


@dataclass(frozen=True)
class QuickSizes:
    """The sizes ``--quick`` shrinks a run to: the same algorithm, smaller numbers.

    timesteps: slot-decisions in total, at most (the run asked for may be shorter)
    n_envs, batch_decisions, minibatch: env instances, slot-decisions per PPO update and per minibatch
    checkpoint_every: PPO updates between kept checkpoints
    rounds: bilevel alternation rounds, at most
    spline_samples, spline_minibatch: car samples per spline update and per spline minibatch
    checkpoint_every_rounds: bilevel rounds between kept checkpoints
    """

    timesteps: int = 48_000
    n_envs: int = 8
    batch_decisions: int = 8_000
    minibatch: int = 2_000
    checkpoint_every: int = 2
    rounds: int = 3
    spline_samples: int = 256
    spline_minibatch: int = 128
    checkpoint_every_rounds: int = 1


QUICK = QuickSizes()


@dataclass
class CommonArgs:
    """Arguments every training script takes.

    num_cars: cars per episode
    lidar_noise: share of LiDAR rays dropped each decision
    seed: random seed
    quick: a real but short run (48,000 decisions: seconds of training on two idle cores)
    out: output folder (must not exist unless --resume)
    resume: continue the run in --out from its last checkpoint
    ent_coef: entropy bonus (default: 0.01)
    critic: mean (the paper), own+mean, or own (decentralised baseline)
    n_envs: env instances simulated side by side
    batch_decisions: slot-decisions per PPO update
    epochs: PPO epochs per update
    minibatch_by_step: minibatches of whole env steps: the critic encodes each step's team once, about 1.7x
        faster training at equal sample efficiency (--no-minibatch-by-step: minibatches of single transitions,
        the default before)
    threads: torch CPU threads (default: while collecting rollouts the cores the env worker processes leave free,
        during the update every core)
    num_cpus: worker processes stepping the envs (0: in the learner's process; same rollouts either way; the
        instances go in runs of ceil(n_envs / num_cpus), so 16 instances over 15 workers start 8 processes)
    transport: how env worker processes hand each step to the learner: shared (shared memory, a car's full
        info only at its end; the default) or supersuit (SuperSuit's ProcConcatVec); same rollouts either way
    overlap: with env workers, step the next decision while the learner files the last one (same rollouts
        and weights; --no-overlap: SB3's own rollout loop)
    device: where the networks run: auto (CUDA if torch sees a GPU), cpu or cuda
    max_minutes: stop once the run has trained this many wall-clock minutes (all sessions)
    init_from: start from this checkpoint's weights (e.g. fine-tune a 4-car policy with 8 cars)
    horizon: episode horizon in decisions (default: the scenario's)
    collision_reward: reward on a car's first collision (default: the scenario's, -1 as in the paper)
    remove_collided: take a collided car out of the world instead of leaving it as a wreck
    preset: a named preset of world and training settings: paper (the paper's own code: its world, 20
        instances, updates of 32,000 joint steps in one pass of 20 minibatches, entropy 1e-4;
        docs/paper_world.md); flags given with other than their default values still win (a
        --batch-decisions given keeps the preset's 20 minibatches)
    original_epochs: the budget in the original's unit, epochs of 32,000 joint steps (each num_cars
        slot-decisions); overrides --timesteps
    lidar_encoder: the networks' LiDAR encoder: original (the paper's code: linear, one channel,
        kernel 4, stride 2; the default) or relu (ours until 2026-12-06: 8 channels, kernel 5, ReLU
        after each convolution; its last ReLU can die, leaving the actor blind); default: original,
        or with --init-from the encoder of those weights
    value_targets: what the critic learns towards: lambda_returns (SB3's, the default, and the
        paper preset's so far) or rewards_to_go (the paper's code: discounted rewards)
    """

    num_cars: int = DrivingConfig.num_cars
    lidar_noise: float = DrivingConfig.lidar_noise
    seed: int = TrainConfig.seed
    quick: bool = False
    out: str = "runs/run"
    resume: bool = False
    ent_coef: Optional[float] = None  # None: TrainConfig's (or the preset's)
    critic: str = TrainConfig.critic
    n_envs: int = TrainConfig.n_envs
    batch_decisions: int = TrainConfig.batch_decisions
    epochs: int = TrainConfig.epochs
    minibatch_by_step: bool = TrainConfig.minibatch_by_step
    threads: Optional[int] = TrainConfig.threads
    num_cpus: int = TrainConfig.num_cpus
    transport: str = TrainConfig.transport
    overlap: bool = TrainConfig.overlap
    device: str = TrainConfig.device
    max_minutes: Optional[float] = TrainConfig.max_minutes
    init_from: Optional[str] = TrainConfig.init_from
    horizon: Optional[int] = None
    collision_reward: Optional[float] = None
    remove_collided: bool = False
    preset: Optional[str] = None
    original_epochs: Optional[int] = None
    lidar_encoder: Optional[str] = None
    value_targets: Optional[str] = None

    def env_overrides(self) -> dict:
        """Scenario-specific config overrides a script adds (none by default)."""
        return {}


@dataclass
class ScriptArgs(CommonArgs):
    """timesteps: slot-decisions to train for in total"""

    timesteps: int = TrainConfig.timesteps


def init_from_encoder(init_from: str) -> Optional[str]:
    """The LiDAR encoder of the weights ``--init-from`` names; None where they cannot be read (the
    trainer then refuses them, naming why, before it writes anything: in a sweep that trial fails
    alone)."""
    from training.runs.checkpoint import CheckpointError, read_checkpoint
    from training.runs.weights import weights_encoder

    try:
        return weights_encoder(read_checkpoint(init_from).policy)
    except CheckpointError:
        return None


def config_from(env_id: str, args: CommonArgs, timesteps: Optional[int] = None) -> TrainConfig:
    """The :class:`TrainConfig` a behaviour script's arguments ask for on ``env_id``: env settings
    from the flags, the rest as given (``timesteps``: instead of ``args.timesteps``)."""
    overrides = {} if args.preset is None else preset_overrides(args.preset, env_id)
    overrides.update({"num_cars": args.num_cars, "lidar_noise": args.lidar_noise})
    overrides.update(args.env_overrides())
    if args.horizon is not None:
        overrides["horizon"] = args.horizon
    if args.collision_reward is not None:
        overrides["collision_reward"] = args.collision_reward
    if args.remove_collided:  # runs without it keep their recorded overrides
        overrides["remove_collided"] = True
    cfg = TrainConfig(
        env_id=env_id, env_overrides=overrides,
        timesteps=timesteps if timesteps is not None else cast(ScriptArgs, args).timesteps, seed=args.seed,
        n_envs=args.n_envs, batch_decisions=args.batch_decisions, epochs=args.epochs,
        minibatch_by_step=args.minibatch_by_step,
        critic=args.critic, threads=args.threads, num_cpus=args.num_cpus, transport=args.transport,
        overlap=args.overlap, device=args.device,
        max_minutes=args.max_minutes,
        init_from=args.init_from,
        ent_coef=TrainConfig.ent_coef if args.ent_coef is None else args.ent_coef, preset=args.preset,
    )
    if args.preset is not None:  # the preset's update, then any size given away from its default
        preset = training_preset(args.preset)
        preset.apply(cfg, args.num_cars)
        defaults = type(args)()
        given = {name: getattr(args, name) for name in ("n_envs", "batch_decisions", "epochs")
                 if getattr(args, name) != getattr(defaults, name)}
        preset.resize(cfg, **given)
        if args.ent_coef is not None:
            cfg.ent_coef = args.ent_coef
    if args.lidar_encoder is not None:
        cfg.lidar_encoder = args.lidar_encoder
    elif args.preset is None and args.init_from:  # a fine-tune builds the encoder of its weights
        cfg.lidar_encoder = init_from_encoder(args.init_from) or cfg.lidar_encoder
    if args.value_targets is not None:
        cfg.value_targets = args.value_targets
    if args.original_epochs is not None:
        if args.original_epochs < 1:
            raise ConfigError(f"--original-epochs must be >= 1, got {args.original_epochs}")
        joint = training_preset(args.preset).joint_steps_per_update if args.preset else 32_000
        cfg.timesteps = args.original_epochs * joint * args.num_cars
    if args.quick:
        cfg.n_envs, cfg.batch_decisions, cfg.minibatch = QUICK.n_envs, QUICK.batch_decisions, QUICK.minibatch
        cfg.timesteps = min(cfg.timesteps, QUICK.timesteps)
        cfg.checkpoint_every = QUICK.checkpoint_every
    cfg.validate()  # fields set after construction (the preset's, the flags'): a bad one named now
    return cfg


@dataclass
class BilevelArgs(CommonArgs):
    """Arguments of the bilevel (spline + acceleration) scripts.

    rounds: alternation rounds (spline update, then acceleration updates)
    spline_samples: car samples per spline update
    spline_updates_per_round: spline PPO updates per round (K1 = this x spline_samples)
    accel_updates_per_round: acceleration PPO updates per round (K2 = this x batch_decisions)
    spline_learning_rate: learning rate of the spline policy
    spline_ent_coef: entropy bonus of the spline policy
    spline_init_from: start the spline policy from this bilevel run folder
    checkpoint_every: rounds between kept checkpoints
    """

    rounds: int = BilevelConfig.rounds
    spline_samples: int = BilevelConfig.spline_samples
    spline_updates_per_round: int = BilevelConfig.spline_updates_per_round
    accel_updates_per_round: int = BilevelConfig.accel_updates_per_round
    spline_learning_rate: float = BilevelConfig.spline_learning_rate
    spline_ent_coef: float = BilevelConfig.spline_ent_coef
    spline_init_from: Optional[str] = BilevelConfig.spline_init_from
    checkpoint_every: int = BilevelConfig.checkpoint_every


def bilevel_config_from(env_id: str, args: BilevelArgs) -> BilevelConfig:
    """The :class:`~training.trainers.bilevel.BilevelConfig` of a spline behaviour's arguments:
    the acceleration stage as :func:`config_from` builds it, the rounds and spline settings from
    the flags."""
    accel = config_from(env_id, args, timesteps=0)
    cfg = BilevelConfig(
        accel=accel, rounds=args.rounds, spline_samples=args.spline_samples,
        accel_updates_per_round=args.accel_updates_per_round,
        spline_updates_per_round=args.spline_updates_per_round,
        spline_learning_rate=args.spline_learning_rate, spline_ent_coef=args.spline_ent_coef,
        checkpoint_every=args.checkpoint_every, max_minutes=args.max_minutes,
        spline_init_from=args.spline_init_from, spline_n_envs=accel.n_envs,
    )
    if args.quick:
        cfg.rounds = min(args.rounds, QUICK.rounds)
        cfg.spline_samples, cfg.spline_minibatch = QUICK.spline_samples, QUICK.spline_minibatch
        cfg.checkpoint_every = QUICK.checkpoint_every_rounds
    return cfg
