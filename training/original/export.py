"""An original-code run's actor as a policy of ours, to drive our ``paper`` preset world.

sdriving 0.1.0's actor (``PPOLidarCategoricalActor``, hidden sizes 256, 256, tanh) and our actor
with the paper code's LiDAR encoder (``lidar_encoder="original"``) are the same network with
other names, and one more difference: its first layer reads ``[sat-nav history, 25 LiDAR
features]``, ours ``[25 LiDAR features, sat-nav history]``, so that layer's columns are moved.
Both observations hold the same values in the same order otherwise (five frames oldest first of
the light, ``speed / 8``, the heading error to the goal and ``1 / max(distance, 1)``; rays
counter-clockwise from the heading, ``1 / distance`` or 0), and both action lists are the 13
accelerations -1.5, -1.25, ..., 1.5 m/s^2.

:func:`export_policy` writes the actor as a policy folder (``model.safetensors`` with the actor
only, as a sweep keeps its trials, and ``config.json``: the ``paper`` preset with the run's cars
and noise), which ``box2d-driving evaluate --checkpoint``, ``render --policy`` and
``box2d_driving.policies.load_trained`` read as any policy of ours.
"""

from __future__ import annotations

import dataclasses
import json
from pathlib import Path
from typing import Any, Optional

import numpy as np

from training.original.commands import OriginalError

# sdriving's actor names (as the worker stores them, under "actor.") -> ours (under "policy/")
RENAMES = {
    "actor.lidar_features.0.weight": "policy/mlp_extractor.actor_encoder.conv.0.weight",
    "actor.lidar_features.0.bias": "policy/mlp_extractor.actor_encoder.conv.0.bias",
    "actor.lidar_features.1.weight": "policy/mlp_extractor.actor_encoder.conv.1.weight",
    "actor.lidar_features.1.bias": "policy/mlp_extractor.actor_encoder.conv.1.bias",
    "actor.logits_net.0.weight": "policy/mlp_extractor.actor_mlp.0.weight",
    "actor.logits_net.0.bias": "policy/mlp_extractor.actor_mlp.0.bias",
    "actor.logits_net.2.weight": "policy/mlp_extractor.actor_mlp.2.weight",
    "actor.logits_net.2.bias": "policy/mlp_extractor.actor_mlp.2.bias",
    "actor.logits_net.4.weight": "policy/action_net.weight",
    "actor.logits_net.4.bias": "policy/action_net.bias",
}
FIRST_LAYER = "actor.logits_net.0.weight"


def convert_actor(tensors: dict[str, np.ndarray], pooled: int = 25) -> dict[str, np.ndarray]:
    """Our actor's tensors (``policy/...`` names) from an original actor's (``actor....``; other
    tensors, the critic's and the optimisers', are left out): renamed, and the first layer's
    columns moved from ``[sat-nav, features]`` to ``[features, sat-nav]``. :class:`OriginalError`
    naming a missing tensor."""
    missing = [k for k in RENAMES if k not in tensors]
    if missing:
        raise OriginalError(f"not an original actor: {missing[0]} is missing")
    out = {ours: np.ascontiguousarray(tensors[theirs], dtype=np.float32) for theirs, ours in RENAMES.items()}
    first = np.asarray(tensors[FIRST_LAYER], dtype=np.float32)
    n_satnav = first.shape[1] - pooled
    if n_satnav < 1:
        raise OriginalError(f"{FIRST_LAYER} reads {first.shape[1]} values, fewer than the {pooled} LiDAR features")
    out[RENAMES[FIRST_LAYER]] = np.ascontiguousarray(np.concatenate([first[:, n_satnav:], first[:, :n_satnav]], axis=1))
    return out


def to_original(tensors: dict[str, np.ndarray], pooled: int = 25) -> dict[str, np.ndarray]:
    """The inverse of :func:`convert_actor`: an actor of ours with the paper code's LiDAR
    encoder (``policy/...`` names, as a checkpoint or kept trial stores them) under sdriving's
    names, to drive the original world. :class:`OriginalError` for an actor with our own encoder
    (its 8-channel convolutions have no counterpart there) or a missing tensor."""
    if "policy/mlp_extractor.actor_encoder.conv.2.weight" in tensors:
        raise OriginalError("this actor has our own LiDAR encoder (lidar_encoder='relu'): only one with the "
                            "paper code's ('original') runs in the original's network")
    missing = [ours for ours in RENAMES.values() if ours not in tensors]
    if missing:
        raise OriginalError(f"not an actor of ours: {missing[0]} is missing")
    out = {theirs: np.ascontiguousarray(tensors[ours], dtype=np.float32) for theirs, ours in RENAMES.items()}
    first = out[FIRST_LAYER]
    out[FIRST_LAYER] = np.ascontiguousarray(np.concatenate([first[:, pooled:], first[:, :pooled]], axis=1))
    return out


def original_spec(config: dict[str, Any]) -> dict[str, Any]:
    """The original world's settings (a ``run.json`` for the worker's rollouts) for a policy of
    ours trained in the ``paper`` preset's world (its run ``config``): its cars, noise and spawn
    rule; :class:`OriginalError` for a policy of another world or encoder."""
    from box2d_driving.presets import preset_overrides
    from training.original.commands import OriginalRun

    env = config.get("env_overrides", {})
    if config.get("env_id") != "intersection-v0" or config.get("preset") not in ("paper", "paper-turns"):
        raise OriginalError(f"the policy was trained on {config.get('env_id')} with preset {config.get('preset')}: "
                            f"the original's world is the intersection of the paper or paper-turns preset")
    turns = config.get("preset") == "paper-turns"
    if config.get("lidar_encoder") != "original":
        raise OriginalError("this actor has our own LiDAR encoder (lidar_encoder='relu'): only one with the "
                            "paper code's ('original') runs in the original's network")
    horizon = preset_overrides(str(config.get("preset")), "intersection-v0")["horizon"]  # the original's, in decisions
    if env.get("horizon", horizon) != horizon:
        raise OriginalError(f"the policy's horizon is {env['horizon']} decisions; the original's world has {horizon}")
    order = env.get("approach_order", "rotate")
    if order not in ("rotate", "random"):
        raise OriginalError(f"approach_order={order!r} has no counterpart in the original's world")
    return OriginalRun(lidar_noise=float(env.get("lidar_noise", 0.0)), epochs=1, nagents=int(env.get("num_cars", 4)),
                       balance_cars=order == "rotate", turns=turns).spec()


def preset_config(spec: dict[str, Any], car_decisions: int) -> Any:
    """Our run config of the ``paper`` preset (``paper-turns`` for a run on the turning junction)
    with an original run's cars, LiDAR noise, spawn rule (``balance_cars``) and horizon;
    ``car_decisions``: what it trained on, recorded as ``timesteps``. Refuses a run whose world
    no preset covers (turns without right-of-way lights or the reverse) or whose horizon is not a
    whole number of decisions."""
    from box2d_driving.presets import preset_overrides
    from training.trainers.presets import training_preset
    from training.trainers.train_config import TrainConfig

    env = spec["env_kwargs"]
    if bool(env.get("turns")) != bool(env.get("learn_right_of_way")):
        raise OriginalError("run.json sets one of turns and learn_right_of_way: the paper-turns preset's world has "
                            "both, the paper preset's neither")
    preset = "paper-turns" if env.get("turns") else "paper"
    if env["horizon"] % env["timesteps"]:
        raise OriginalError(f"run.json: horizon {env['horizon']} is not a whole number of decisions of "
                            f"{env['timesteps']} steps")
    overrides = {**preset_overrides(preset, "intersection-v0"), "num_cars": int(env["nagents"]),
                 "lidar_noise": float(env["lidar_noise"]), "horizon": env["horizon"] // env["timesteps"],
                 "approach_order": "rotate" if env.get("balance_cars", True) else "random"}
    config = TrainConfig(env_id="intersection-v0", env_overrides=overrides, seed=int(spec["seed"]),
                         timesteps=max(1, int(car_decisions)), preset=preset)
    training_preset(preset).apply(config, int(env["nagents"]))
    config.validate()
    return config


def export_policy(run: Path, weights: Path, out: Path, epoch: Optional[int] = None) -> Path:
    """Write the actor of ``weights`` (a file of the original run folder ``run``, kept after
    ``epoch``; None: the run's last) to the new folder ``out`` as our policy (see the module
    docstring); returns ``out``. Written beside it and renamed, so ``out`` is whole or absent; an
    existing ``out`` is refused."""
    from safetensors.numpy import load_file, save_file

    from box2d_driving.policies.checkpoint_file import FORMAT, VERSION

    if out.exists():
        raise OriginalError(f"--out {out} exists (choose another folder)")
    spec = json.loads((run / "run.json").read_text())
    state = json.loads((run / "state.json").read_text()) if (run / "state.json").is_file() else {}
    config = preset_config(spec, int(state.get("car_decisions", 1)))
    tensors = convert_actor(load_file(str(weights)))
    tmp = out.with_name(out.name + ".partial")
    tmp.mkdir(parents=True, exist_ok=False)
    save_file(tensors, str(tmp / "model.safetensors"), metadata={
        "format": FORMAT, "version": str(VERSION),
        "counters": json.dumps({"num_timesteps": config.timesteps, "n_updates": int(state.get("epochs_done", 0))})})
    (tmp / "config.json").write_text(json.dumps({"algorithm": "ppo", **dataclasses.asdict(config)}, indent=2) + "\n")
    # where the actor came from, for a reader of the folder (nothing loads it)
    (tmp / "source.json").write_text(json.dumps({"original_run": run.name, "weights": weights.name,
                                                 "epoch": state.get("epochs_done") if epoch is None else epoch},
                                                indent=1) + "\n")
    tmp.rename(out)
    return out

