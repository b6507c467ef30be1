"""Runs inside the sdriving virtual environment (never imported by box2d-driving).

The paper's own code, sdriving 0.1.0, trains with ``sdriving.agents.ppo_distributed`` under
Horovod and Weights & Biases. This script runs that trainer's own rollout (``episode_runner``) and
update (``update``) in one process, with Horovod stubbed as a single worker and wandb as a no-op,
and keeps what a resumable run needs in plain files:

* ``weights.safetensors``: actor, critic, both Adam states and torch's random state;
* ``state.json``: epochs done, joint steps, car-decisions, seconds, numpy's and Python's random
  states (the next epoch is a function of these and the weights, so a resumed run continues
  bit for bit where it stopped);
* ``progress.csv``: one row per epoch;
* ``actors/epoch_NNNN.safetensors``: the actor every 5 epochs and at the end, for learning curves.

One Horovod worker instead of the original's 20 changes one thing: the original sums the
gradients of its 20 workers' minibatches (each 1/20 of that worker's share of the epoch), this
runs the same epoch in one buffer with minibatches 20 times larger and averages; Adam divides
the gradient by its own running scale, so the update is the same up to Adam's epsilon.

Usage (by ``box2d-driving original train``): ``python sdriving_worker.py train RUN_FOLDER
--time-limit MINUTES``; ``RUN_FOLDER/run.json`` holds the run's settings.
"""

from __future__ import annotations

import argparse
import csv
import importlib.machinery
import json
import os
import random
import sys
import time
import types
from typing import Any, cast

WEIGHTS = "weights.safetensors"
STATE = "state.json"
PROGRESS = "progress.csv"
RUN = "run.json"
ACTORS = "actors"
SNAPSHOT_EVERY = 5  # epochs between kept actors (run.json's "snapshot_every" overrides)
PROGRESS_COLUMNS = ("epoch", "joint_steps", "car_decisions", "episodes", "episode_return", "entropy",
                    "kl", "stop_iter", "seconds")


def _stub(name: str, **attrs) -> types.ModuleType:
    mod = types.ModuleType(name)
    mod.__spec__ = importlib.machinery.ModuleSpec(name, None)  # torch's import scans look for one
    for key, value in attrs.items():
        setattr(mod, key, value)
    sys.modules[name] = mod
    return mod


class _Unavailable:
    def __init__(self, *args, **kwargs):
        raise RuntimeError("not available in this stubbed sdriving environment")


def install_stubs() -> None:
    """Stand-ins for the modules sdriving imports but a one-process CPU run does not use."""
    import torch

    identity = lambda x, *args, **kwargs: x  # noqa: E731 (single worker: every reduction is the value)
    _stub("horovod")
    _stub("horovod.torch", allreduce=identity, allgather=identity, Average=0, Sum=1, size=lambda: 1,
          rank=lambda: 0, local_rank=lambda: 0, local_size=lambda: 1, init=lambda: None,
          broadcast_parameters=lambda *a, **k: None, broadcast_optimizer_state=lambda *a, **k: None)
    nothing = lambda *args, **kwargs: None  # noqa: E731
    _stub("wandb", init=nothing, watch=nothing, save=nothing, log=nothing,
          config=types.SimpleNamespace(update=nothing))
    _stub("nuscenes")
    _stub("nuscenes.map_expansion")
    _stub("nuscenes.map_expansion.map_api", NuScenesMap=_Unavailable)
    _stub("nuscenes.map_expansion.arcline_path_utils", discretize_lane=None)
    _stub("cv2")
    _stub("fire", Fire=None)
    _stub("sklearn")
    _stub("sklearn.neighbors", KDTree=_Unavailable)
    for name in ("seaborn", "shapely"):
        try:
            __import__(name)
        except ImportError:
            _stub(name)
    if "shapely" in sys.modules and not hasattr(sys.modules["shapely"], "geometry"):
        _stub("shapely.geometry", LineString=_Unavailable, Polygon=_Unavailable)
    torch.set_num_threads(1)


# -- carry: weights and random states in files that cannot run code ------------------------------
def _optimizer_tensors(prefix: str, optimizer) -> dict:
    out = {}
    for index, state in optimizer.state_dict()["state"].items():
        for key, value in state.items():
            out[f"{prefix}.{index}.{key}"] = value.detach().clone().contiguous()
    return out


def _load_optimizer(prefix: str, optimizer, tensors: dict) -> None:
    import torch

    saved = optimizer.state_dict()
    state: dict = {}
    for name, value in tensors.items():
        if name.startswith(prefix + "."):
            index, key = name[len(prefix) + 1:].split(".", 1)
            state.setdefault(int(index), {})[key] = value.clone() if key != "step" else value.to(torch.float32)
    saved["state"] = state
    optimizer.load_state_dict(saved)


def save_carry(folder: str, trainer, state: dict) -> None:
    """Write weights, optimisers and random states (atomically: a kill leaves the old or the new)."""
    import numpy as np
    import torch
    from safetensors.torch import save_file

    tensors = {f"actor.{k}": v.detach().clone().contiguous() for k, v in trainer.ac.pi.state_dict().items()}
    tensors.update({f"critic.{k}": v.detach().clone().contiguous() for k, v in trainer.ac.v.state_dict().items()})
    tensors.update(_optimizer_tensors("pi_opt", trainer.pi_optimizer))
    tensors.update(_optimizer_tensors("vf_opt", trainer.vf_optimizer))
    tensors["rng.torch"] = torch.get_rng_state()
    if trainer.env.cached_actions is not None:  # the env's smoothness term reads it across resets
        tensors["env.cached_actions"] = trainer.env.cached_actions.detach().clone().contiguous()
    kind, keys, pos, has_gauss, gauss = cast(tuple[str, Any, int, int, float], np.random.get_state())
    py_version, py_state, py_gauss = random.getstate()
    state = dict(state, numpy_rng={"kind": kind, "keys": keys.tolist(), "pos": int(pos),
                                   "has_gauss": int(has_gauss), "gauss": float(gauss)},
                 python_rng={"version": py_version, "state": list(py_state), "gauss": py_gauss})
    for name, write in ((WEIGHTS, lambda p: save_file(tensors, p)),
                        (STATE, lambda p: _write_json(p, state))):
        tmp = os.path.join(folder, name + ".partial")
        write(tmp)
        os.replace(tmp, os.path.join(folder, name))


def save_actor(folder: str, trainer, epoch: int) -> str:
    """The actor after ``epoch`` epochs, alone (``actors/epoch_NNNN.safetensors``, 0.3 MB): the
    points of the run's learning curve (``box2d-driving original evaluate`` scores any of them)."""
    from safetensors.torch import save_file

    os.makedirs(os.path.join(folder, ACTORS), exist_ok=True)
    path = os.path.join(folder, ACTORS, f"epoch_{epoch:04d}.safetensors")
    tensors = {f"actor.{k}": v.detach().clone().contiguous() for k, v in trainer.ac.pi.state_dict().items()}
    save_file(tensors, path + ".partial")
    os.replace(path + ".partial", path)
    return path


def _write_json(path: str, data: dict) -> None:
    with open(path, "w") as f:
        json.dump(data, f)


def load_carry(folder: str, trainer) -> dict:
    import numpy as np
    import torch
    from safetensors.torch import load_file

    tensors = load_file(os.path.join(folder, WEIGHTS))
    with open(os.path.join(folder, STATE)) as f:
        state = json.load(f)
    trainer.ac.pi.load_state_dict({k[6:]: v for k, v in tensors.items() if k.startswith("actor.")})
    trainer.ac.v.load_state_dict({k[7:]: v for k, v in tensors.items() if k.startswith("critic.")})
    _load_optimizer("pi_opt", trainer.pi_optimizer, tensors)
    _load_optimizer("vf_opt", trainer.vf_optimizer, tensors)
    torch.set_rng_state(tensors["rng.torch"])
    trainer.env.cached_actions = tensors.get("env.cached_actions")
    n = state["numpy_rng"]
    np.random.set_state((n["kind"], np.array(n["keys"], dtype=np.uint32), n["pos"], n["has_gauss"], n["gauss"]))
    p = state["python_rng"]
    random.setstate((p["version"], tuple(p["state"]), p["gauss"]))
    return state


# -- training ------------------------------------------------------------------------------------
def build_trainer(folder: str, run: dict):
    """sdriving's own trainer, built as its ``train.py`` builds it from the original command."""
    import numpy as np
    import torch
    from sdriving.agents.ppo_distributed.ppo import PPO_Distributed_Centralized_Critic
    from sdriving.environments import REGISTRY

    # the original seeds after building the env (whose first map then depends on the unseeded
    # generators); seeding first makes the run a function of its seed
    torch.manual_seed(run["seed"])
    np.random.seed(run["seed"])
    random.seed(run["seed"])
    t = run["trainer"]
    return PPO_Distributed_Centralized_Critic(
        REGISTRY[run["env"]], dict(run["env_kwargs"]), os.path.join(folder, "sdriving_log"),
        ac_kwargs=dict(run["ac_kwargs"]), seed=run["seed"], steps_per_epoch=t["steps_per_epoch"],
        epochs=run["epochs"], gamma=t["gamma"], clip_ratio=t["clip_ratio"], pi_lr=t["pi_lr"], vf_lr=t["vf_lr"],
        train_iters=t["train_iters"], lam=t["lam"], target_kl=t["target_kl"], save_freq=run["epochs"] + 1,
        load_path=None, entropy_coeff=t["entropy_coeff"])


def _mean(values) -> float:
    import numpy as np

    values = [float(v) for v in values]
    return float(np.mean(values)) if values else float("nan")


def train(folder: str, time_limit_s: float) -> int:
    install_stubs()
    with open(os.path.join(folder, RUN)) as f:
        run = json.load(f)
    trainer = build_trainer(folder, run)
    state = {"epochs_done": 0, "joint_steps": 0, "car_decisions": 0, "episodes": 0, "seconds": 0.0}
    if os.path.exists(os.path.join(folder, STATE)):
        state = load_carry(folder, trainer)
        print(f"resumed at epoch {state['epochs_done']} of {run['epochs']}", flush=True)
    progress = os.path.join(folder, PROGRESS)
    if not os.path.exists(progress):
        with open(progress, "w", newline="") as f:
            csv.writer(f).writerow(PROGRESS_COLUMNS)
    else:  # drop rows past the carried epoch (a kill between the row and the carry)
        with open(progress, newline="") as f:
            rows = list(csv.reader(f))
        keep = [rows[0]] + [r for r in rows[1:] if int(r[0]) <= state["epochs_done"]]
        with open(progress, "w", newline="") as f:
            csv.writer(f).writerows(keep)
    started, longest = time.monotonic(), 0.0
    while state["epochs_done"] < run["epochs"]:
        elapsed = time.monotonic() - started
        if elapsed + longest > time_limit_s:
            print(f"time limit: stopped after epoch {state['epochs_done']} of {run['epochs']}", flush=True)
            return 3
        t0 = time.monotonic()
        trainer.episode_runner()
        decisions = int(trainer.buf.mask_buf.sum().item())
        trainer.update()
        stats = trainer.logger.epoch_dict
        episodes = len(stats.get("EpisodeReturn", []))
        row = dict(epoch=state["epochs_done"] + 1, joint_steps=trainer.local_steps_per_epoch,
                   car_decisions=decisions, episodes=episodes,
                   episode_return=_mean(stats.get("EpisodeReturn", [])), entropy=_mean(stats.get("Entropy", [])),
                   kl=_mean(stats.get("KL", [])), stop_iter=_mean(stats.get("StopIter", [])),
                   seconds=0.0)
        for key in list(stats):  # the logger's per-epoch store, emptied as its dump_tabular would
            stats[key] = []
        seconds = time.monotonic() - t0
        longest = max(longest, seconds)
        row["seconds"] = round(seconds, 2)
        state["epochs_done"] += 1
        state["joint_steps"] += row["joint_steps"]
        state["car_decisions"] += decisions
        state["episodes"] += episodes
        state["seconds"] = round(state["seconds"] + seconds, 2)
        with open(progress, "a", newline="") as f:
            csv.writer(f).writerow([row[c] for c in PROGRESS_COLUMNS])
        save_carry(folder, trainer, state)
        every = run.get("snapshot_every", SNAPSHOT_EVERY)
        if every and (state["epochs_done"] % every == 0 or state["epochs_done"] == run["epochs"]):
            save_actor(folder, trainer, int(state["epochs_done"]))
        print(f"epoch {state['epochs_done']}/{run['epochs']}: {decisions} car-decisions, {episodes} episodes, "
              f"return {row['episode_return']:.3f}, {seconds:.0f} s", flush=True)
    return 0


# -- rollouts: the original world driven by a scripted or trained driver, as our table -----------
DRIVERS = ("full-throttle", "constant-speed", "rule", "random", "trained")
COLLIDED_WITH = ("", "car", "edge", "pedestrian")  # box2d_driving.metrics.rollouts.COLLIDED_WITH


def constant_speed_actions(levels, speed, v_lim, period: float, fraction: float):
    """The constant-speed driver (``box2d_driving.policies.scripted.ConstantSpeedPolicy``, the same
    rule): for each car the index of the acceleration level (m/s^2) nearest to ``(fraction * v_lim
    - speed) / period``, the lower on a tie; ``speed`` and ``v_lim`` per car (m/s), ``period`` the
    seconds of one decision."""
    import numpy as np

    wanted = (fraction * np.asarray(v_lim, dtype=float) - np.asarray(speed, dtype=float)) / period
    return np.argmin(np.abs(np.asarray(levels, dtype=float)[None, :] - wanted[:, None]), axis=1)


def _actor(weights: str, env):
    """The actor of an original-code run (``weights.safetensors``), deterministic (arg max)."""
    from safetensors.torch import load_file
    from sdriving.agents.model import PPOLidarActorCritic

    ac = PPOLidarActorCritic(env.observation_space, env.action_space, nagents=env.nagents, centralized=True,
                             hidden_sizes=[256, 256], history_len=5, permutation_invariant=True)
    tensors = load_file(weights)
    ac.pi.load_state_dict({k[6:]: v for k, v in tensors.items() if k.startswith("actor.")})
    ac.eval()
    return ac


def rollout(run_spec: dict, driver: str, episodes: int, first_seed: int, out: str, weights: str | None,
            target_fraction: float = 0.5) -> None:
    """``episodes`` episodes of the original env, episode ``k`` seeded with ``first_seed + k``
    (torch, numpy and Python's generators), one row per car per decision in the columns of
    ``box2d_driving.metrics.rollouts`` (x right, y up, m; speed m/s; angles rad). Row ``decision
    == 0`` is the state at reset. A car's rows end on its collision decision or at the horizon:
    in this world an arrived car stays, so ``arrived`` is true from its arrival decision on.
    ``target_fraction``: the constant-speed driver's target, a share of the speed limit."""
    import math

    install_stubs()
    import numpy as np
    import torch
    from sdriving.environments import REGISTRY

    env = REGISTRY[run_spec["env"]](**run_spec["env_kwargs"])
    levels = env.action_list[:, -1].numpy()
    n_act = len(levels)
    actor: Any = None
    if driver == "trained":
        if weights is None:
            raise ValueError("the trained driver needs its weights file")
        actor = _actor(weights, env)
    columns: dict[str, list] = {name: [] for name in (
        "episode", "car", "decision", "x", "y", "heading", "speed", "acceleration", "light", "in_junction",
        "lane_offset", "distance_to_goal", "arrived", "collided", "reward", "approach", "rating",
        "stop_line_distance", "pedestrian_distance", "crosswalk_distance", "bit_sent", "collided_with",
        "collision_partner", "partner_halted", "lidar_returns", "lidar_nearest", "satnav_heading", "satnav_goal")}
    car_hits: dict[str, Any] = {}
    original_check = env.vehicle_collision_check

    def recording_check(vehicle):  # which new collisions were with another car
        hit = original_check(vehicle)
        car_hits["now"] = car_hits.get("now", torch.zeros_like(hit)) | hit
        return hit

    env.vehicle_collision_check = recording_check
    for k in range(episodes):
        seed = first_seed + k
        torch.manual_seed(seed)
        np.random.seed(seed % 2**32)
        random.seed(seed)
        rng = np.random.default_rng(seed)
        (obs, lidar), names = env.reset()
        env.cached_actions = None  # each episode on its own (training carries it across resets)
        n = env.nagents
        vehicle = env.agents["agent"]
        start_dir = torch.cat([torch.cos(vehicle.orientation), torch.sin(vehicle.orientation)], -1).numpy()
        approach = np.round(np.arctan2(start_dir[:, 1], start_dir[:, 0]) / (math.pi / 2)).astype(int) % 4
        half = env.width / 2
        live = np.ones(n, dtype=bool)
        accel = np.zeros(n)
        reward = np.zeros(n)
        hit_with = np.zeros(n, dtype=int)
        decision = 0
        while True:
            pos = vehicle.position.numpy().astype(float)
            speed = vehicle.speed[:, 0].numpy().astype(float)
            heading = vehicle.orientation[:, 0].numpy().astype(float)
            togo = vehicle.distance_from_destination()[:, 0].numpy().astype(float)
            # the sat-nav as get_state reads it (an arrived car's destination is moved onto it)
            heading_read = vehicle.optimal_heading()[:, 0].numpy().astype(float)
            goal_read = 1.0 / np.maximum(togo, 1.0)
            light = env.world.get_all_traffic_signal().numpy().astype(float)  # what get_state reads
            rays = env.world.get_lidar_data_all_vehicles(run_spec["env_kwargs"]["npoints"]).numpy()  # m, noise-free
            returns = np.isfinite(rays).sum(-1)
            nearest = rays.min(-1)
            arrived = env.completion_vector[:, 0].numpy()
            collided = env.collision_vector[:, 0].numpy()
            along = (pos * start_dir).sum(-1)
            right = np.stack([start_dir[:, 1], -start_dir[:, 0]], -1)
            for i in np.flatnonzero(live):
                for name, value in (("episode", k), ("car", i), ("decision", decision), ("x", pos[i, 0]),
                                    ("y", pos[i, 1]), ("heading", heading[i]), ("speed", speed[i]),
                                    ("acceleration", accel[i]), ("light", light[i]),
                                    ("in_junction", bool(abs(pos[i, 0]) <= half and abs(pos[i, 1]) <= half)),
                                    ("lane_offset", float((pos[i] * right[i]).sum() / half)),
                                    ("distance_to_goal", togo[i]), ("arrived", bool(arrived[i])),
                                    ("collided", bool(collided[i])), ("reward", reward[i]),
                                    ("approach", int(approach[i])), ("rating", 1.0),
                                    ("stop_line_distance", float(-half - along[i])),
                                    ("pedestrian_distance", math.nan), ("crosswalk_distance", math.nan),
                                    ("bit_sent", math.nan), ("collided_with", int(hit_with[i])),
                                    ("collision_partner", -1), ("partner_halted", False),
                                    ("lidar_returns", int(returns[i])), ("lidar_nearest", float(nearest[i])),
                                    ("satnav_heading", heading_read[i]), ("satnav_goal", goal_read[i])):
                    columns[name].append(value)
            live &= ~collided
            if not live.any() or decision >= run_spec["env_kwargs"]["horizon"] // run_spec["env_kwargs"]["timesteps"]:
                break
            if driver == "full-throttle":
                act = np.full(n, n_act - 1)
            elif driver == "constant-speed":  # the dynamics' own limit and the decision's seconds
                act = constant_speed_actions(levels, speed, env.dynamics.v_lim[:, 0].numpy(),
                                             env.timesteps * env.dynamics.dt, target_fraction)
            elif driver == "rule":
                act = np.where(np.isin(light, (0.5, 1.0)), 0, n_act - 1)
            elif driver == "random":
                act = rng.integers(n_act, size=n)
            else:
                with torch.no_grad():
                    act = actor.act((obs, lidar), deterministic=True).numpy().reshape(n)
            car_hits.clear()
            before = env.collision_vector[:, 0].numpy().copy()
            (nxt, _), r, done, _ = env.step(torch.as_tensor(act, dtype=torch.long))
            decision += 1
            accel = levels[act].astype(float)
            reward = r[:, 0].numpy().astype(float)
            new = env.collision_vector[:, 0].numpy() & ~before
            by_car = car_hits.get("now", torch.zeros(n, dtype=torch.bool)).numpy().reshape(n)
            hit_with = np.where(new, np.where(by_car, 1, 2), hit_with)
            if nxt is not None:  # None once every car is done (its last rows read the world itself)
                obs, lidar = nxt
    table = {name: np.asarray(values) for name, values in columns.items()}
    np.savez_compressed(out, **table)  # type: ignore[arg-type]  # numpy's stub types the keywords as its flags


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    t = sub.add_parser("train")
    t.add_argument("folder")
    t.add_argument("--time-limit", type=float, default=float("inf"), help="minutes")
    r = sub.add_parser("rollout")
    r.add_argument("run_json")
    r.add_argument("--driver", choices=DRIVERS, required=True)
    r.add_argument("--weights", default=None)
    r.add_argument("--episodes", type=int, required=True)
    r.add_argument("--first-seed", type=int, required=True)
    r.add_argument("--out", required=True)
    r.add_argument("--target-fraction", type=float, default=0.5,
                   help="the constant-speed driver's target speed, a share of the speed limit")
    args = parser.parse_args(argv)
    if args.command == "rollout":
        with open(args.run_json) as f:
            rollout(json.load(f), args.driver, args.episodes, args.first_seed, args.out, args.weights,
                    args.target_fraction)
        return 0
    return train(args.folder, args.time_limit * 60.0)


if __name__ == "__main__":
    sys.exit(main())
