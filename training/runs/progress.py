"""What a training run logs while it learns, and its checkpoints: the rollout statistics
callback (success, collisions, red-light violations, agent-steps/s; progress bar) and
``save_checkpoint``."""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path
from typing import Any, Callable, Optional

import numpy as np
import torch as th
from stable_baselines3 import PPO
from stable_baselines3.common.callbacks import BaseCallback
from stable_baselines3.common.utils import explained_variance

from box2d_driving.metrics.lights import violation_rate
from box2d_driving.outputs import GracefulStop
from box2d_driving.road.lights import NO_LIGHT
from training.ppo.buffer import MaskedRolloutBuffer
from training.ppo.encoder import BLIND_SPREAD, lidar_spread
from training.runs.checkpoint import save_model
from training.runs.run_dir import set_root_checkpoint


# rows of the rollout (evenly spaced over its live cars) the actor's LiDAR encoder is measured on
SPREAD_ROWS = 2048


class RolloutMetrics(BaseCallback):
    """Per update: success, collision and red-light violation rates of the episodes that ended,
    agent-steps (padding excluded), throughput (``time/agent_steps_per_s`` includes the PPO update
    before the rollout, ``time/rollout_agent_steps_per_s`` is collection only), and whether the
    actor still reads its LiDAR (``rollout/lidar_input_spread`` and ``rollout/lidar_feature_spread``:
    the largest standard deviation over the rollout's observations of the LiDAR values and of the
    actor's pooled LiDAR features; features constant while the inputs vary mean a dead encoder, warned
    of once); logged to CSV/TensorBoard; progress bar."""

    model: PPO  # SB3 types it as any algorithm; this callback is given to PPO runs (bilevel's included)

    def __init__(self, out: Path, total: float, wall_offset: float, agent_steps_offset: int,
                 checkpoint_every: int, max_seconds: float = math.inf, show_bar: bool = True,
                 stop: Optional[GracefulStop] = None,
                 on_checkpoint: Optional[Callable[[dict], None]] = None) -> None:
        super().__init__()
        self.on_checkpoint = on_checkpoint
        self.stop = stop
        self.show_bar = show_bar
        self.max_seconds = max_seconds
        self.out, self.total = out, total
        self.wall_offset, self.agent_steps = wall_offset, agent_steps_offset
        self.checkpoint_every = checkpoint_every
        self.updates = 0
        self.bar: Any = None  # a tqdm bar from the start of training
        self.warned_blind = False

    def _on_training_start(self) -> None:
        from tqdm import tqdm

        n = self.training_env.num_envs
        self.prev_light = np.full(n, NO_LIGHT)
        self.prev_inside = np.zeros(n, dtype=bool)
        self.t0 = self.prev_rollout_end = time.perf_counter()
        self.interactive = sys.stderr.isatty()
        self.bar = tqdm(total=self.total, initial=self.num_timesteps, unit="dec", smoothing=0.1,
                        dynamic_ncols=True, mininterval=0.5 if self.interactive else 30.0,
                        disable=not self.show_bar, desc="collecting")
        self._reset_stats()

    def _reset_stats(self) -> None:
        self.done_cars = self.arrived = self.collided = self.ped_hits = 0
        self.entry_lights: list[float] = []
        self.rollout_t0 = time.perf_counter()
        self.rollout_agent_steps = 0

    def _on_step(self) -> bool:
        infos, dones = self.locals["infos"], self.locals["dones"]
        for slot, info in enumerate(infos):
            if not info:
                continue
            self.rollout_agent_steps += 1
            inside = info["in_junction"]
            if inside and not self.prev_inside[slot]:
                self.entry_lights.append(self.prev_light[slot])
            self.prev_light[slot], self.prev_inside[slot] = info["light"], inside
            if dones[slot]:
                self.done_cars += 1
                self.arrived += info["arrived"]
                self.collided += info["collided"]
                self.ped_hits += info["collided_with"] == "pedestrian"
                self.prev_light[slot], self.prev_inside[slot] = NO_LIGHT, False
        self.bar.update(self.training_env.num_envs)
        return self.wall < self.max_seconds and not (self.stop is not None and self.stop.requested)

    def _on_rollout_end(self) -> None:
        now = time.perf_counter()
        self.agent_steps += self.rollout_agent_steps
        v = violation_rate(np.array(self.entry_lights))
        cars = max(self.done_cars, 1)
        stats = {
            "rollout/success_rate": self.arrived / cars,
            "rollout/collision_rate": self.collided / cars,
            "rollout/pedestrian_collision_rate": self.ped_hits / cars,
            "rollout/red_light_violation_rate": v.rate,
            "rollout/stop_value": v.stop_value,
            "rollout/junction_entries": v.entries,
            "rollout/cars_done": self.done_cars,
            "time/agent_steps": self.agent_steps,
            "time/wall_s": self.wall,
            # with the PPO update before this rollout: what training runs at
            "time/agent_steps_per_s": self.rollout_agent_steps / max(now - self.prev_rollout_end, 1e-9),
            # collecting the rollout only (env stepping and inference, no update)
            "time/rollout_agent_steps_per_s": self.rollout_agent_steps / max(now - self.rollout_t0, 1e-9),
        }
        self.prev_rollout_end = now
        buf = self.model.rollout_buffer
        if isinstance(buf, MaskedRolloutBuffer):  # SB3's own figure includes the padding
            live = buf.mask
            stats["rollout/explained_variance_live"] = float(
                explained_variance(buf.values[live], buf.returns[live]))
            stats.update(self._lidar_spread(buf))
        for k, val in stats.items():
            self.logger.record(k, val)
        self.bar.set_postfix(success=f"{stats['rollout/success_rate']:.2f}",
                             crash=f"{stats['rollout/collision_rate']:.2f}",
                             viol=f"{v.rate:.2f}", refresh=False)
        # the PPO update comes next and moves no decision counter: say so, or the bar seems stuck
        self.bar.set_description_str("updating", refresh=self.interactive)
        self.updates += 1
        self.last_stats = stats
        self._reset_stats()

    def _lidar_spread(self, buf: MaskedRolloutBuffer) -> dict[str, float]:
        """The rollout's LiDAR input and actor feature spreads (none for a policy without the
        actor's encoder); warns once when the features stopped varying while the inputs vary."""
        net: Any = getattr(self.model.policy, "mlp_extractor", None)
        encoder = getattr(net, "actor_encoder", None)
        live = np.flatnonzero(buf.mask.reshape(-1))
        if encoder is None or len(live) < 2:
            return {}
        rows = live[np.linspace(0, len(live) - 1, min(len(live), SPREAD_ROWS)).astype(np.int64)]
        flat: np.ndarray = np.asarray(buf.observations).reshape(-1, buf.observations.shape[-1])
        obs = flat[rows][:, : net.obs_dim]
        inputs, features = lidar_spread(encoder, th.as_tensor(obs, device=self.model.policy.device))
        if inputs > BLIND_SPREAD and features < BLIND_SPREAD and not self.warned_blind:
            self.warned_blind = True
            self.bar.write(f"warning: at {self.num_timesteps:,} decisions the actor's LiDAR features no longer "
                           f"vary (spread {features:.1e}, the LiDAR's {inputs:.2f}): its encoder is dead and it "
                           "drives blind to the other cars; `--lidar-encoder original` (linear) cannot die "
                           "(docs/paper_world.md, \"The LiDAR encoder\")", file=sys.stderr)
        return {"rollout/lidar_input_spread": inputs, "rollout/lidar_feature_spread": features}

    def _on_rollout_start(self) -> None:
        if self.bar is not None:
            self.bar.set_description_str("collecting", refresh=self.interactive)
        if self.updates and self.updates % self.checkpoint_every == 0:
            save_checkpoint(self.model, self.out, self.wall, self.agent_steps)
            if self.on_checkpoint is not None:
                self.on_checkpoint(self.progress())
        self.rollout_t0 = time.perf_counter()

    def _on_training_end(self) -> None:
        self.bar.set_description_str("trained", refresh=False)
        self.bar.close()

    def progress(self) -> dict:
        """The last rollout's statistics and the run's counters (what a checkpoint hook gets)."""
        return {**getattr(self, "last_stats", {}), "time/decisions": self.num_timesteps,
                "time/agent_steps": self.agent_steps, "time/wall_s": self.wall}

    @property
    def wall(self) -> float:
        return self.wall_offset + time.perf_counter() - self.t0


def save_checkpoint(model: PPO, out: Path, wall_s: float, agent_steps: int) -> Path:
    """Write ``checkpoints/model_<decisions>.safetensors``, refresh ``model.safetensors`` and
    ``state.json`` (each replaced whole, so an interruption leaves the previous ones; the kept copy
    is written first and carries the run's state, so a kill between the writes loses nothing:
    ``training/runs/resume.py``)."""
    ckpt_dir = out / "checkpoints"
    ckpt_dir.mkdir(exist_ok=True)
    run_state = {"wall_s": wall_s, "agent_steps": agent_steps}
    path = save_model(model, ckpt_dir / f"model_{model.num_timesteps}.safetensors", run_state=run_state)
    set_root_checkpoint(out, path, model.num_timesteps, agent_steps, wall_s)
    return path
