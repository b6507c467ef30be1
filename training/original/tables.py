"""Rollout tables of trained policies in either world, for ``box2d-driving original``: an
original run's actor or a policy of ours, driving sdriving's own environment (through the worker
in the sdriving environment ``original setup`` builds) or our ``paper`` preset's, and their
scores by our metric code."""

from __future__ import annotations

import json
import os
import subprocess
import tempfile
from pathlib import Path
from typing import Optional

from training.original.commands import OriginalError

WORKER = Path(__file__).with_name("sdriving_worker.py")
def venv_dir() -> Path:
    """Where ``original setup`` puts the sdriving environment (``BOX2D_DRIVING_SDRIVING_VENV``
    overrides)."""
    env = os.environ.get("BOX2D_DRIVING_SDRIVING_VENV")
    if env:
        return Path(env)
    cache = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache"))
    return cache / "box2d-driving" / "sdriving-venv"


def require_venv() -> None:
    """:class:`OriginalError` unless ``original setup`` has built the sdriving environment."""
    if not venv_python().exists():
        raise OriginalError(f"no sdriving environment at {venv_dir()}: run `box2d-driving original setup` first")


def venv_python() -> Path:
    return venv_dir() / "bin" / "python"


def score_table(table: dict) -> dict:
    """Our traffic-light report of a rollout table of the original world: the lights summary
    (violations with their adopted stop value, success, collisions, time to goal) and the rates'
    95 % intervals with episodes as clusters."""
    from box2d_driving.metrics.intervals import rate_intervals
    from box2d_driving.metrics.lights import traffic_light_metrics

    # the original's hardest braking, -1.5 m/s^2 (fixed_track.py, configure_action_space)
    metrics = traffic_light_metrics(table, max_brake=1.5)
    metrics["intervals"] = rate_intervals(table, ("success_rate", "collision_rate", "red_light_violation_rate"))
    return metrics


def latest_weights(run: Path) -> Path:
    """The weights of a run's last epoch: ``weights.safetensors`` (actor, critic and optimiser
    state, kept while the run can be resumed), else, for a finished run carried without it, the
    actor kept after its last epoch (``actors/epoch_NNNN.safetensors``, NNNN from ``state.json``)."""
    full = run / "weights.safetensors"
    if full.is_file() or not (run / "state.json").is_file():
        return full
    try:
        done = int(json.loads((run / "state.json").read_text())["epochs_done"])
    except (OSError, ValueError, KeyError, TypeError):
        return full
    return run / "actors" / f"epoch_{done:04d}.safetensors"


def run_weights(run: Path, epoch: Optional[int]) -> Path:
    """The actor file of run folder ``run`` after ``epoch`` (None: its last), checked to exist
    with the run's ``run.json``: :class:`OriginalError` naming what is missing."""
    weights = latest_weights(run) if epoch is None else run / "actors" / f"epoch_{epoch:04d}.safetensors"
    for path in (run / "run.json", weights):
        if not path.is_file():
            raise OriginalError(f"--run {run}: {path.relative_to(run)} is missing")
    return weights


def trained_our_table(policy_path: Path, episodes: int, first_seed: int, overrides: Optional[dict] = None) -> dict:
    """The rollout table of a policy of ours (a folder ``load_trained`` reads) driving its own
    world (the ``paper`` preset's, for an exported original actor), with ``overrides`` of that
    world's config."""
    from box2d_driving.metrics.rollouts import run_episodes
    from box2d_driving.policies import load_trained

    policy = load_trained(policy_path)
    env = policy.make_env(**(overrides or {}))
    try:
        return run_episodes(env, policy, episodes, seed=first_seed)
    finally:
        env.close()


def trained_original_table(spec_path: Path, weights: Path, episodes: int, first_seed: int, table_path: Path) -> None:
    """Write the rollout table of an actor in sdriving's names (``weights``) driving the original
    world of ``spec_path`` (a ``run.json``), through the worker."""
    subprocess.run([str(venv_python()), str(WORKER), "rollout", str(spec_path), "--driver", "trained",
                    "--weights", str(weights), "--episodes", str(episodes), "--first-seed", str(first_seed),
                    "--out", str(table_path)], check=True, stderr=subprocess.DEVNULL)


def policy_source(policy: Path) -> tuple[dict, dict]:
    """A policy of ours as the original's actor: (run.json for the worker, sdriving tensors)."""
    from box2d_driving.policies.checkpoint_file import find_config, read_arrays, read_json
    from box2d_driving.policies.shipped import resolve_policy_path
    from training.original.export import original_spec, to_original

    path, arrays, _ = read_arrays(resolve_policy_path(policy))  # policy arrays by state_dict name
    return original_spec(read_json(find_config(path))), to_original({f"policy/{k}": v for k, v in arrays.items()})


def write_table(table_path: Path, world: str, episodes: int, first_seed: int, *, run: Optional[Path] = None,
                weights: Optional[Path] = None, epoch: Optional[int] = None, policy: Optional[Path] = None,
                original: Optional[tuple[dict, dict]] = None, overrides: Optional[dict] = None) -> None:
    """Write to ``table_path`` the rollout table of ``episodes`` report episodes from
    ``first_seed`` in ``world`` (``"original"`` or ``"ours"``, with ``overrides`` of our world's
    config) driven by an original ``run``'s actor ``weights`` (kept after ``epoch``; None: its
    last), or by a policy of ours (``policy``; for the original world, ``original`` is its
    :func:`policy_source`, read beforehand so that a policy the original cannot run is refused
    before anything is written)."""
    from safetensors.numpy import save_file

    from box2d_driving.metrics.rollouts import save_table
    from training.original.export import export_policy

    with tempfile.TemporaryDirectory() as tmp:
        if run is not None and weights is not None and world == "original":
            trained_original_table(run / "run.json", weights, episodes, first_seed, table_path)
        elif run is not None and weights is not None:
            exported = export_policy(run, weights, Path(tmp) / "policy", epoch)
            save_table(trained_our_table(exported, episodes, first_seed, overrides), table_path)
        elif policy is not None and world == "original":
            spec, actor = original if original is not None else policy_source(policy)
            (Path(tmp) / "run.json").write_text(json.dumps(spec))
            save_file(actor, str(Path(tmp) / "actor.safetensors"))
            trained_original_table(Path(tmp) / "run.json", Path(tmp) / "actor.safetensors", episodes, first_seed,
                                   table_path)
        elif policy is not None:
            save_table(trained_our_table(policy, episodes, first_seed, overrides), table_path)
        else:
            raise OriginalError("a rollout table needs an original run's weights or a policy of ours")


def driver_table(table_path: Path, driver: str, world: str, episodes: int, first_seed: int, cars: int,
                 turns: bool = False, overrides: Optional[dict] = None) -> None:
    """Write to ``table_path`` the rollout table of the scripted ``driver`` on ``episodes`` report
    episodes from ``first_seed``: in the original world (the noise runs' junction with ``cars``
    cars, or with ``turns`` the 1-car run's turning junction; LiDAR noise 0, which no scripted
    driver reads), or in ours (the ``paper`` preset, ``paper-turns`` with ``turns``, and
    ``overrides``; spawn rules checked against the original's as ``original compare`` does)."""
    from box2d_driving.metrics.rollouts import run_episodes, save_table
    from box2d_driving.policies.scripted import make_policy
    from box2d_driving.registry import make
    from training.original.compare import check_spawns, original_table

    if world == "original":
        original_table(venv_python(), WORKER, driver, episodes, first_seed, cars, table_path, turns)
        return
    preset = "paper-turns" if turns else "paper"
    for key, flag in (("num_cars", "--cars"), ("turns", "--turns")):
        if key in (overrides or {}):  # one way to say it, so the report's cars and world are the ones driven
            raise OriginalError(f"--set {key}: a scripted driver's world takes it from {flag}")
    check_spawns(cars, overrides or {}, preset)
    env = make("intersection-v0", preset=preset, **{"num_cars": cars, **(overrides or {})})
    try:
        save_table(run_episodes(env, make_policy(driver, env, seed=first_seed), episodes, seed=first_seed), table_path)
    finally:
        env.close()
