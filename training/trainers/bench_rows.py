"""One row of ``box2d-driving bench --train``: training throughput of one setting, measured.

Measures agent-steps per second of real PPO training, updates included (one agent-step is one
decision of one live car; padding slots are not counted), for one :class:`TrainConfig` (our
defaults or a preset's world and update; :mod:`training.trainers.bench_train` picks them). A row
runs ``warmup`` updates (not timed: Numba kernels compile, workers start), then ``updates`` timed
ones, and splits the timed wall clock into:

* ``env``: waiting for the vector env's step (stepping the envs in-process, or waiting for the
  workers and copying their observations);
* ``inference``: the rest of the rollout (the policy's forward pass, the rollout buffer, callbacks);
* ``update``: PPO's epochs over the batch.

Each row also gives those three as milliseconds per step of the vector env (one step: every
instance one decision), the joint steps per second (one joint step: one instance one decision;
the paper's trainer counts its epoch as 32,000 of them), and a **limit**: the same vector env
(same instances, same worker processes) stepped for as many steps with uniform random actions and
no learner at all, after an untimed warm-up of as many steps as the warm-up updates took. The
limit is what the env side delivers on that machine; training throughput over the limit is the
share of it the learner lets through (the rest is the forward pass and the update, during which
the env side waits).

After the timed updates each row runs PPO's epochs once more on the last batch, timed alone, and
once under ``torch.utils.flop_counter.FlopCounterMode`` to count the floating-point operations of
the update's matrix products and convolutions (forward and backward; element-wise operations are
not counted; the LiDAR convolutions counted as convolutions, not as the zero-padded products
``training/ppo/encoder.py`` computes them with). Their ratio is the update's achieved GFLOP/s,
printed beside a plain matrix product of the update's widest layer (minibatch x 256 times
256 x 256) timed in the same run on the same device and threads: how close the learner comes to
what the machine can do. Beside it, the same update timed once more with both LiDAR encoders
replaced by stand-ins that cost next to nothing (:func:`training.ppo.encoder.encoders_cost_nothing`),
over the same counted GFLOP: the most any faster encoder could give.
"""

from __future__ import annotations

import tempfile
import time
from dataclasses import dataclass
from typing import Any, Optional, cast

import torch as th
from gymnasium import spaces

from stable_baselines3.common.callbacks import BaseCallback

from training.trainers.trainer import (TrainConfig, build_model, make_vec_env, resolve_device, set_minibatching,
                                       torch_threads, update_threads)


@dataclass
class TrainBenchRow:
    """One measured setting of ``bench --train`` (the module docstring defines each figure).

    Attributes:
        num_cpus: env workers asked for (``--num-cpus``; 0: the envs step in the learner's process).
        worker_processes: the worker processes that ran: the instances go in runs of
            ``ceil(n_envs / num_cpus)``, so 16 instances over 15 workers are 8 processes of 2.
        device: torch device of the learner.
        threads: torch threads while collecting rollouts.
        update_threads: torch threads during the update (by default every core: the workers wait).
        agent_steps_per_s: live agent-steps per wall-clock second over the timed updates.
        agent_steps: live agent-steps in the timed updates.
        seconds: wall clock of the timed updates (s).
        env_share, inference_share, update_share: the three parts of that wall clock.
        update_gflop: counted floating-point work of one update (GFLOP).
        update_gflops: that work over the update's own time (GFLOP/s).
        bound_gflops: the same work over the time with the encoders replaced by free stand-ins.
        matmul_gflops: a plain product of the update's widest layer, same device and threads.
        steps: vector-env steps in the timed updates (every instance one decision each).
        env_ms, inference_ms, update_ms: the three parts per vector-env step (ms).
        limit_agent_steps_per_s: the same vector env stepped with random actions, no learner.
        joint_steps_per_s: joint env steps per wall-clock second over the timed updates (one joint
            step: one instance one decision, every car of it deciding; the original trainer's epoch
            is 32,000 of them).
        transport: how the worker processes hand each step over (``shared`` or ``supersuit``;
            ``-`` without workers).
        overlap: whether the overlapped rollout loop ran (:mod:`training.ppo.overlapped`; only
            with workers).
        lidar_encoder: the actor's and critic's LiDAR encoder (``original`` or ``relu``:
            :mod:`training.ppo.encoder`).
    """

    num_cpus: int
    worker_processes: int
    device: str
    threads: int
    agent_steps_per_s: float
    agent_steps: int
    seconds: float
    env_share: float
    inference_share: float
    update_share: float
    update_gflop: float
    update_gflops: float
    bound_gflops: float
    matmul_gflops: float
    steps: int = 0
    env_ms: float = 0.0
    inference_ms: float = 0.0
    update_ms: float = 0.0
    limit_agent_steps_per_s: float = 0.0
    transport: str = "-"
    overlap: bool = False
    update_threads: int = 0
    joint_steps_per_s: float = 0.0
    lidar_encoder: str = "original"


class _Clock(BaseCallback):
    """Splits wall time into rollouts and updates; counts live agent-steps after the warm-up."""

    def __init__(self, warmup: int, env_timer: "_TimedStep") -> None:
        super().__init__()
        self.warmup = warmup
        self.env_timer = env_timer
        self.rollouts = 0
        self.t_start: Optional[float] = None
        self.rollout_s = 0.0
        self.agent_steps = 0
        self.steps = 0  # vector-env steps timed
        self._t = 0.0

    @property
    def timing(self) -> bool:
        return self.rollouts >= self.warmup

    def _on_rollout_start(self) -> None:
        if self.timing and self.t_start is None:
            self.t_start = time.perf_counter()
            self.env_timer.seconds = 0.0
        self._t = time.perf_counter()

    def _on_step(self) -> bool:
        if self.timing:
            self.agent_steps += sum(1 for info in self.locals["infos"] if info)
            self.steps += 1
        return True

    def _on_rollout_end(self) -> None:
        if self.timing:
            self.rollout_s += time.perf_counter() - self._t
        self.rollouts += 1


class _TimedStep:
    """Accumulates in ``seconds`` the time a vector env spends in ``step_wait``."""

    def __init__(self, venv: Any) -> None:
        inner = venv.step_wait
        self.seconds = 0.0

        def timed() -> Any:
            t0 = time.perf_counter()
            try:
                return inner()
            finally:
                self.seconds += time.perf_counter() - t0

        venv.step_wait = timed


def _timed_update(model) -> tuple[float, int]:
    """Seconds and epochs of one PPO update on the model's last batch."""
    before = model._n_updates
    t0 = time.perf_counter()
    model.train()
    return time.perf_counter() - t0, model._n_updates - before


def update_flops(model) -> tuple[float, float, float]:
    """FLOPs of one PPO update on the model's last batch (matrix products and convolutions,
    forward and backward), the seconds the same update takes without counting, and the seconds it
    takes with the LiDAR encoders costing nothing; both times scaled to the epochs the counted
    update ran (PPO may stop early on its KL target)."""
    from torch.utils.flop_counter import FlopCounterMode

    from training.ppo.encoder import encoders_cost_nothing, reference_convolutions

    seconds, timed_epochs = _timed_update(model)
    counter = FlopCounterMode(display=False)
    before = model._n_updates
    with counter, reference_convolutions():  # the model's own operations, not the fast way's zeros
        model.train()
    counted_epochs = model._n_updates - before
    with encoders_cost_nothing():
        bound_s, bound_epochs = _timed_update(model)
    return (float(counter.get_total_flops()), seconds * counted_epochs / max(1, timed_epochs),
            bound_s * counted_epochs / max(1, bound_epochs))


def matmul_gflops(rows: int, width: int, device: str, repeats: int = 50) -> float:
    """GFLOP/s of a ``(rows, width) @ (width, width)`` product on ``device`` (best of 3)."""
    a = th.randn(rows, width, device=device)
    b = th.randn(width, width, device=device)
    best = 0.0
    for _ in range(3):
        a @ b
        if device == "cuda":
            th.cuda.synchronize()
        t0 = time.perf_counter()
        for _ in range(repeats):
            a @ b
        if device == "cuda":
            th.cuda.synchronize()
        best = max(best, 2.0 * rows * width * width * repeats / (time.perf_counter() - t0) / 1e9)
    return best


def limit_rate(config: TrainConfig, warmup_steps: int, steps: int) -> float:
    """Live agent-steps per second of ``config``'s vector env (its instances, its worker processes)
    stepped ``steps`` times with uniform random actions and no learner, after ``warmup_steps``
    untimed ones: what the env side delivers without training."""
    import numpy as np

    th.set_num_threads(torch_threads(config))  # as while collecting rollouts, not the update's
    venv = make_vec_env(config)
    try:
        venv.seed(config.seed)
        venv.reset()
        rng = np.random.default_rng(config.seed)
        n = int(cast(spaces.Discrete, venv.action_space).n)
        for _ in range(warmup_steps):
            venv.step(rng.integers(n, size=venv.num_envs))
        live = 0
        t0 = time.perf_counter()
        for _ in range(steps):
            live += sum(1 for info in venv.step(rng.integers(n, size=venv.num_envs))[3] if info)
        return live / (time.perf_counter() - t0)
    finally:
        venv.close()


def bench_row(config: TrainConfig, warmup: int, updates: int) -> TrainBenchRow:
    """Train ``warmup + updates`` PPO updates of ``config`` and time the last ``updates``; then
    the limit row: the same vector env with random actions and no learner, as many steps."""
    th.set_num_threads(torch_threads(config))
    venv = make_vec_env(config)
    try:
        env_timer = _TimedStep(venv)
        model = build_model(config, venv)
        overlap = model.overlaps(venv)
        set_minibatching(model, config, venv.n_cars)
        venv.seed(config.seed)
        with tempfile.TemporaryDirectory() as tmp:
            from stable_baselines3.common.logger import configure

            model.set_logger(configure(tmp, []))
            clock = _Clock(warmup, env_timer)
            per_update = model.n_steps * venv.num_envs
            model.learn(per_update * (warmup + updates), callback=clock)
            assert clock.t_start is not None  # set at the first timed rollout
            wall = time.perf_counter() - clock.t_start
            flops, update_s, bound_s = update_flops(model)
            n_steps = model.n_steps
    finally:
        venv.close()
    env_s = env_timer.seconds
    inference_s, learn_s = max(0.0, clock.rollout_s - env_s), max(0.0, wall - clock.rollout_s)
    per_step = 1000.0 / max(1, clock.steps)
    limit = limit_rate(config, n_steps * warmup, clock.steps)
    return TrainBenchRow(
        num_cpus=config.num_cpus, worker_processes=venv.worker_processes, device=resolve_device(config.device),
        threads=torch_threads(config),
        agent_steps_per_s=clock.agent_steps / wall, agent_steps=clock.agent_steps, seconds=wall,
        env_share=env_s / wall, inference_share=inference_s / wall,
        update_share=learn_s / wall, update_gflop=flops / 1e9,
        update_gflops=flops / update_s / 1e9, bound_gflops=flops / bound_s / 1e9,
        matmul_gflops=matmul_gflops(config.minibatch, 256, resolve_device(config.device)),
        steps=clock.steps, env_ms=env_s * per_step, inference_ms=inference_s * per_step,
        update_ms=learn_s * per_step, limit_agent_steps_per_s=limit,
        transport=config.transport if venv.worker_processes else "-", overlap=overlap,
        update_threads=update_threads(config), joint_steps_per_s=clock.steps * config.n_envs / wall,
        lidar_encoder=config.lidar_encoder)
