"""PPO with the centralised critic on a :class:`SlotVecEnv`: building, logging, checkpoints,
resuming. Scripts (``training/behaviours/traffic_lights.py`` ...) only fill in a :class:`TrainConfig`.

Output folder::

    OUT/config.json          full config (trainer + env), written once
    OUT/config.resumed_<decisions>.json  the config each --resume was given (seed, budget, entropy)
    OUT/model.safetensors    latest checkpoint: weights, optimiser state, counters (what
                             load_policy / evaluate / --resume read; see training/runs/checkpoint.py)
    OUT/checkpoints/         model_<decisions>.safetensors every ``checkpoint_every`` updates
    OUT/progress.csv         one row per update: rollout metrics and PPO diagnostics
                             (each --resume adds progress.resumed_<decisions>.csv)
    OUT/events.out.tfevents.*  TensorBoard logs (``tensorboard --logdir OUT``)
    OUT/state.json           wall-clock seconds and agent-steps so far (kept across --resume)
    OUT/.lock                held while a process trains in the folder (training/runs/lock.py)

A killed run resumes from its newest complete checkpoint, root or kept (training/runs/resume.py).
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import shutil
import sys
from pathlib import Path
from typing import Any, Callable, Optional, cast

import torch as th
from stable_baselines3 import PPO
from stable_baselines3.common.logger import configure

from training.ppo.buffer import MaskedRolloutBuffer
from box2d_driving.policies.checkpoint_file import LEGACY_FILE, legacy_message, read_json
from box2d_driving.policies.numpy_actor import is_actor_key
from training.runs.checkpoint import FILE, CheckpointError, read_checkpoint, restore_model
from training.runs.lock import locked_run
from training.runs.resume import ResumePoint, cut_back, resume_point, started_files
from training.runs.inference import find_config
from box2d_driving.config import ConfigError
from box2d_driving.outputs import GracefulStop
from training.ppo.encoder import LEGACY_LIDAR_ENCODER
from training.ppo.policy import CTDEPolicy, policy_kwargs_for
from training.ppo.overlapped import OverlappedPPO
from training.common.seeds import TRAINING
from training.runs.run_dir import RunError, append_logger, check_new, check_same_run, write_config
from training.runs.progress import RolloutMetrics, save_checkpoint
from training.ppo.original_update import ActorStopAdam, KLWatch
from training.ppo.vec_env import SlotVecEnv, make_vec_env_from
from training.ppo.workers import worker_processes
from training.runs.weights import WeightsError, source_fields, weights_encoder, widen_state_dict
from training.trainers.train_config import TrainConfig


def resolve_device(device: str) -> str:
    """``auto``: CUDA when torch sees a GPU, else the CPU. Asking for ``cuda`` without one is an
    error (not a silent fall-back)."""
    if device == "auto":
        return "cuda" if th.cuda.is_available() else "cpu"
    if device == "cuda" and not th.cuda.is_available():
        raise ConfigError("TrainConfig: device='cuda' but torch sees no GPU (a CPU-only torch build, "
                          "or no driver); use --device auto or cpu")
    return device


def torch_threads(config: "TrainConfig") -> int:
    """Torch threads for the learner while it collects rollouts: as configured, else the cores the
    env worker processes leave free (the processes actually started: 16 instances over 15 workers
    are 8 processes of 2)."""
    if config.threads is not None:
        return config.threads
    return max(1, (os.cpu_count() or 1) - worker_processes(config.n_envs, config.num_cpus))


def update_threads(config: "TrainConfig") -> int:
    """Torch threads for the PPO update: as configured, else every core (the workers wait for the
    next rollout meanwhile, so their cores are free)."""
    return config.threads if config.threads is not None else max(1, os.cpu_count() or 1)


def prepare_run_dir(out: Path, resume: bool, config: TrainConfig) -> Optional[ResumePoint]:
    """Check ``out`` for a new run (absent or empty) or for ``--resume``; for a resume, the
    checkpoint it continues from, the folder cut back to it (``training/runs/resume.py``). A
    folder whose run was killed before its first checkpoint resumes from the start: None, with
    what that run had logged removed. A new run writes nothing here (its folder is filled by
    :func:`start_run_dir` once its model is built)."""
    if not resume:
        check_new(out)
        return None
    if not (out / "config.json").exists():
        if (out / LEGACY_FILE).exists():
            raise RunError(f"--resume: {legacy_message(out / LEGACY_FILE)}")
        raise RunError(f"--resume: no checkpoint in {out} ({FILE}, config.json and state.json needed)")
    check_same_run(read_json(out / "config.json"), config)
    point = resume_point(out)
    if point is None:
        if (out / LEGACY_FILE).exists():
            raise RunError(f"--resume: {legacy_message(out / LEGACY_FILE)}")
        started = started_files(out)
        for path in started:
            shutil.rmtree(path) if path.is_dir() and not path.is_symlink() else path.unlink()
        print(f"{out}: no complete checkpoint (the run stopped before its first one): starting it again"
              + (f"; removed {', '.join(p.name for p in started)}" if started else ""), file=sys.stderr)
        return None
    cut = cut_back(out, point)
    if cut:
        print(f"{out}: resuming from the checkpoint at {point.decisions} decisions; removed what the "
              f"stopped run wrote after it: {', '.join(cut)}", file=sys.stderr)
    return point


def start_run_dir(out: Path, config: TrainConfig) -> None:
    """Create a new run's folder and its ``config.json`` (after every check has passed)."""
    out.mkdir(parents=True, exist_ok=True)
    write_config(out / "config.json", config, "ppo")


def make_vec_env(config: TrainConfig, spline_policy: Any = None) -> SlotVecEnv:
    """The run's slot vector env: ``n_envs`` instances over ``num_cpus`` worker processes
    (``spline_policy``: the path picker of spline scenarios, as in ``make_vec_env_from``)."""
    venv = make_vec_env_from(config.env_id, config.env_overrides, config.n_envs, config.num_cpus, spline_policy,
                             transport=config.transport)
    venv.seed_range = TRAINING  # episodes held out for selection and reports are never trained on
    venv.bootstrap_truncation = config.bootstrap_truncation
    return venv


def build_model(config: TrainConfig, venv: SlotVecEnv) -> OverlappedPPO:
    """SB3 PPO with the centralised-critic policy on ``venv``, its rollout length and minibatch
    from ``config`` for the env's car count."""
    probe = venv.probe.env
    n_cars = len(probe.possible_agents)
    n_steps = config.n_steps(n_cars)
    actor_only = config.kl_stop == "actor"
    policy_kwargs = policy_kwargs_for(probe, config.critic, config.lidar_encoder)
    policy_kwargs.update(optimizer_class=ActorStopAdam, optimizer_kwargs={"eps": config.adam_eps})
    # the initial weights' orthogonal draws depend on torch's thread count: build at the rollout's,
    # whatever an earlier model in this process left set (its update's)
    rollout_threads = torch_threads(config)
    th.set_num_threads(rollout_threads)
    model = OverlappedPPO(
        CTDEPolicy, venv, n_steps=n_steps, batch_size=min(config.minibatch, n_steps * venv.num_envs),
        n_epochs=config.epochs, learning_rate=config.learning_rate, gamma=config.gamma,
        gae_lambda=config.gae_lambda, clip_range=config.clip_range, clip_range_vf=config.clip_range_vf,
        ent_coef=config.ent_coef, target_kl=None if actor_only else config.target_kl,
        normalize_advantage=config.advantage_normalisation == "minibatch",
        max_grad_norm=math.inf if config.max_grad_norm is None else config.max_grad_norm,
        policy_kwargs=policy_kwargs, rollout_buffer_class=MaskedRolloutBuffer,
        rollout_buffer_kwargs={"layout": venv.layout,
                               "per_car_advantages": config.advantage_normalisation == "per_car",
                               "returns_to_go": config.value_targets == "rewards_to_go"},
        seed=config.seed, device=resolve_device(config.device), verbose=0,
    )
    model.overlap = config.overlap
    model.rollout_threads, model.update_threads = rollout_threads, update_threads(config)
    if actor_only:  # the paper's KL rule: buffer, policy and optimiser share one watch
        assert config.target_kl is not None  # TrainConfig refuses kl_stop="actor" without one
        watch = KLWatch(config.target_kl)
        buffer, policy = cast(MaskedRolloutBuffer, model.rollout_buffer), cast(CTDEPolicy, model.policy)
        optimizer = cast(ActorStopAdam, policy.optimizer)
        buffer.kl_watch = policy.kl_watch = optimizer.watch = watch
        optimizer.actor_params = policy.actor_parameters()
    return model


def read_train_config(path: Path) -> TrainConfig:
    """A saved ``config.json`` as a :class:`TrainConfig` (fields a later release added take their
    defaults; fields it dropped are ignored)."""
    saved = json.loads(Path(path).read_text())
    known = {f.name for f in dataclasses.fields(TrainConfig)}
    # a run from before the choice existed was built with ours (the default then)
    return TrainConfig(**{"lidar_encoder": LEGACY_LIDAR_ENCODER, **{k: v for k, v in saved.items() if k in known}})


def resumed_config(out: Path, config: TrainConfig) -> TrainConfig:
    """The model settings of a resumed run: the first leg's (``config.json``: its LiDAR encoder
    too, whatever the default now is), with the entropy bonus, the number of env instances and how
    they run (workers, transport, overlap, threads, device) given now."""
    first = read_train_config(out / "config.json")
    return dataclasses.replace(first, ent_coef=config.ent_coef, n_envs=config.n_envs,
                               threads=config.threads, num_cpus=config.num_cpus, device=config.device,
                               transport=config.transport, overlap=config.overlap)


def load_ppo(run: Path | str, env: Optional[Any] = None) -> OverlappedPPO:
    """An SB3 ``PPO`` (:class:`OverlappedPPO`, whose rollouts overlap env workers and learner) from
    a run folder or a shipped policy (``model.safetensors`` and ``config.json``): the model is built
    from the config and the weights, and where saved the optimiser state and counters, are copied
    in; nothing is unpickled. ``env`` defaults to the run's own :class:`SlotVecEnv`. The result can
    ``predict``, ``learn`` or ``save`` as any PPO."""
    ckpt = read_checkpoint(Path(run))
    config = read_train_config(find_config(ckpt.path))
    model = build_model(config, env if env is not None else make_vec_env(config))
    restore_model(model, ckpt, optimizer=ckpt.optimizer is not None)
    return model


def train(config: TrainConfig, out: Path, resume: bool = False,
          on_checkpoint: Optional[Callable[[dict], None]] = None) -> dict[str, Any]:
    """Train (or continue) a run in ``out``; returns the last rollout statistics.
    ``on_checkpoint(progress)`` is called after every checkpoint is written, the last one included
    (the sweep reports each to Ray Tune with the run folder).

    The folder is locked for the whole run (a second trainer or ``--resume`` of it is refused,
    naming the holder); ``--resume`` continues from the newest complete checkpoint, wherever a
    kill left it; a disk that refuses a write ends the run with one :class:`RunError`, the last
    complete checkpoint kept."""
    out = Path(out)
    config.validate()
    if config.timesteps < 1:
        raise ConfigError(f"TrainConfig: timesteps must be >= 1, got {config.timesteps}")
    with locked_run(out):  # one trainer per folder; a refused write is one line (training/runs/lock.py)
        return _train_locked(config, out, resume, on_checkpoint)


def _train_locked(config: TrainConfig, out: Path, resume: bool,
                  on_checkpoint: Optional[Callable[[dict], None]]) -> dict[str, Any]:
    point = prepare_run_dir(out, resume, config)
    resolve_device(config.device)  # a missing GPU is found before anything is written
    th.set_num_threads(torch_threads(config))
    venv = make_vec_env(config)  # bad env overrides raise here, still before anything is written
    try:
        return _learn(config, out, point, venv, on_checkpoint)
    finally:
        venv.close()


def _learn(config: TrainConfig, out: Path, point: Optional[ResumePoint], venv: SlotVecEnv,
           on_checkpoint: Optional[Callable[[dict], None]]) -> dict[str, Any]:
    wall, agent_steps = 0.0, 0
    resume = point is not None
    if point is not None:
        model = build_model(resumed_config(out, config), venv)
        try:
            restore_model(model, point.checkpoint)
        except CheckpointError as exc:
            raise RunError(f"--resume: {exc}") from None
        wall, agent_steps = point.wall_s, point.agent_steps
        model.set_random_seed(config.seed + model.num_timesteps)  # reproducible continuation
    else:
        model = build_model(config, venv)
        if config.init_from:
            load_weights(model, Path(config.init_from))
        venv.seed(config.seed)
    set_minibatching(model, config, venv.n_cars)
    remaining = config.timesteps - model.num_timesteps
    max_seconds = math.inf if config.max_minutes is None else 60.0 * config.max_minutes
    if remaining <= 0 or wall >= max_seconds:  # a resumed run with nothing left: no new logs
        print(f"{out}: nothing to train: {model.num_timesteps} of {config.timesteps} decisions and "
              f"{wall / 60:.1f} of {max_seconds / 60:.1f} min done", file=sys.stderr)
        return {}
    if resume:  # config.json stays the run's first config; record what this leg was given
        write_config(out / f"config.resumed_{model.num_timesteps:012d}.json", config, "ppo")
    else:
        start_run_dir(out, config)
    model.set_logger(configure(str(out), ["csv", "tensorboard"]) if not resume else
                     append_logger(out, model.num_timesteps))
    stop = GracefulStop()
    callback = RolloutMetrics(out, config.timesteps, wall, agent_steps, config.checkpoint_every,
                              max_seconds, stop=stop, on_checkpoint=on_checkpoint)
    try:
        with stop.installed():  # Ctrl-C / SIGTERM: end the decision in progress, then save below
            model.learn(remaining, callback=callback, reset_num_timesteps=False)
        save_checkpoint(model, out, callback.wall, callback.agent_steps)
    finally:
        model.logger.close()  # the CSV and TensorBoard files flushed and closed, whatever happened
    if on_checkpoint is not None:
        on_checkpoint(callback.progress())
    stats = dict(getattr(callback, "last_stats", {}))
    if stop.requested:
        stats["interrupted_by_signal"] = stop.signum
    return stats


def set_minibatching(model: PPO, config: TrainConfig, n_cars: int) -> None:
    """Apply ``config.minibatch_by_step`` to a built or loaded model (it is not saved with it)."""
    cast(MaskedRolloutBuffer, model.rollout_buffer).group_size = n_cars if config.minibatch_by_step else 1


def load_weights(model: PPO, checkpoint: Path) -> bool:
    """Copy the policy weights (actor, critic) of ``checkpoint`` into ``model``; widened (see
    ``training/runs/weights.py``) when ``model``'s env adds sat-nav fields or the communication bit.

    A sweep trial's kept weights (``assets/sweeps/weights/...``) hold the actor alone: then only
    the actor is copied and the critic keeps its fresh initialisation (as a value function
    learnt for fewer cars would mislead the first updates no less). Returns whether the critic
    was copied too."""
    try:
        source = read_checkpoint(checkpoint)
    except CheckpointError as exc:
        raise RunError(f"--init-from: {exc}") from None
    path = source.path
    full, theirs = model.policy.state_dict(), source.policy
    built, given = weights_encoder(full), weights_encoder(theirs)
    if built != given:
        raise RunError(f"--init-from: {path} was trained with the LiDAR encoder {given!r} and this run builds "
                       f"{built!r}; give --lidar-encoder {given} (sweeps: lidar_encoder={given})")
    actor_keys = {k for k in full if is_actor_key(k)}
    with_critic = full.keys() == theirs.keys()
    if not with_critic and theirs.keys() != actor_keys:
        raise RunError(f"--init-from: {path} has a different network (critic variant?)")
    mine = full if with_critic else {k: v for k, v in full.items() if k in actor_keys}
    bad = [k for k in mine if mine[k].shape != theirs[k].shape]
    if bad:
        env = cast(SlotVecEnv, model.get_env()).probe.env
        try:
            theirs = widen_state_dict(mine, theirs, src_fields=source_fields(path.parent),
                                      dst_fields=env.observation_layout.satnav_fields,
                                      history=env.observation_layout.history)
        except WeightsError as exc:
            raise RunError(f"--init-from: {path} does not fit this env's observation layout "
                           f"(e.g. {bad[0]}: {tuple(theirs[bad[0]].shape)} vs {tuple(mine[bad[0]].shape)}; "
                           f"{exc})") from None
    model.policy.load_state_dict(theirs, strict=with_critic)
    if not with_critic:
        print(f"--init-from: {path} holds the actor alone (kept sweep weights): the critic starts fresh",
              file=sys.stderr)
    return with_critic
