"""Evaluate a checkpoint (or a scripted policy): rollouts, the rule metrics (docs/), plots, a video.

    box2d-driving evaluate --checkpoint runs/lights4 --episodes 200 --out runs/lights4/eval
    box2d-driving evaluate --checkpoint rule --episodes 200 --out runs/rule_eval

Writes ``OUT/rollouts.npz`` (one row per car per decision), ``OUT/metrics.json`` and plots:
``learning_curves.png`` (from the run's logs), what each collided car hit (``collisions`` and
``collisions.png``, every scenario) and the scenario's report (``training/evaluation/reports.py``):
intersection: success_rate, collision_rate, red_light_violation_rate with the adopted stop value,
mean_time_to_goal, ``acceleration_by_light.png``, ``junction_light.png``; crosswalk: safe-stopping
share, pedestrian collision rate (also with pedestrians invisible to the LiDAR), distance KDE and
speed/distance plots. ``--video N`` also records N episodes to ``OUT/episodes.mp4``.
"""

from __future__ import annotations

import dataclasses
import json
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Optional

import box2d_driving
from box2d_driving.metrics.intervals import RATES, rate_intervals
from box2d_driving.metrics.rollouts import run_episodes, save_table
from box2d_driving.policies import SCRIPTED, make_policy
from training.evaluation import plots
from training.evaluation.reports import add_collisions, report_for
from training.common.cli_args import error, parse
from training.common.seeds import REPORT


@dataclass
class Args:
    """Evaluate a policy.

    checkpoint: run folder or model.safetensors, or a scripted policy (random, full-throttle, constant-speed, rule,
        pedestrian-oracle)
    env_id: env for scripted policies (trained ones use the env they were trained on)
    episodes: evaluation episodes
    out: output folder (must not exist unless --overwrite)
    seed: seed of the first episode; every episode seed must be a report seed, never seen in training or
        checkpoint selection (default: the first report seed, 1,500,000,000)
    num_cars: cars (default: as trained; scripted: 4)
    lidar_noise: LiDAR noise (default: as trained; scripted: 0)
    stochastic: sample actions instead of taking the most likely one
    video: episodes to record to OUT/episodes.mp4 (0 = none)
    remove_collided: take collided cars out of the world (--no-remove-collided: leave them as wrecks; neither:
        as trained, scripted policies leave them)
    overwrite: allow writing into an existing output folder
    """

    checkpoint: str = "rule"
    env_id: str = "intersection-v0"
    episodes: int = 200
    out: str = "runs/eval"
    seed: Optional[int] = None
    num_cars: Optional[int] = None
    lidar_noise: Optional[float] = None
    stochastic: bool = False
    video: int = 0
    remove_collided: Optional[bool] = None
    overwrite: bool = False


def evaluate(args: Args) -> dict:
    """Evaluate into ``args.out``: everything is written to a hidden sibling folder that replaces
    ``args.out`` whole when the report is complete (``--overwrite`` leaves no stale files; an error
    or an interruption leaves the earlier report untouched and nothing half-written)."""
    from box2d_driving.outputs import fresh_dir

    out = Path(args.out)
    if out.exists() and any(out.iterdir()) and not args.overwrite:
        raise FileExistsError(f"{out} exists and is not empty; choose another --out or pass --overwrite")
    if args.episodes < 1:
        raise ValueError(f"--episodes must be >= 1, got {args.episodes}")
    if args.video < 0:
        raise ValueError(f"--video must be >= 0, got {args.video}")
    seeds = REPORT.episodes(args.episodes, args.seed)  # reports only ever on report seeds
    args = dataclasses.replace(args, seed=seeds.start)
    with fresh_dir(out, args.overwrite) as tmp:
        return _evaluate_into(tmp, args)


def _evaluate_into(out: Path, args: Args) -> dict:
    assert args.seed is not None  # evaluate() set it to the first report seed
    seed = args.seed
    extra = {k: v for k, v in (("num_cars", args.num_cars), ("lidar_noise", args.lidar_noise))
             if v is not None}
    if args.remove_collided is not None:
        extra["remove_collided"] = args.remove_collided
    run_dir, env_id = None, args.env_id
    if args.checkpoint in SCRIPTED:
        def make_env(**kw):
            return box2d_driving.make(env_id, **extra, **kw)
        env = make_env()
        policy = make_policy(args.checkpoint, env, seed=seed)
        source = {"policy": args.checkpoint}
    else:
        import torch

        from training.runs.inference import load_policy

        torch.set_num_threads(1)  # batches of a few cars: one thread is fastest
        policy = load_policy(args.checkpoint, deterministic=not args.stochastic)

        def make_env(**kw):
            return policy.make_env(**extra, **kw)
        env = make_env()
        env_id = policy.env_id
        path = Path(args.checkpoint)
        run_dir = path if path.is_dir() else path.parent
        source = {"checkpoint": str(path), "trained_on": policy.config["env_overrides"]}
    t0 = time.perf_counter()
    table = run_episodes(env, policy, args.episodes, seed=seed)
    seconds = time.perf_counter() - t0
    save_table(table, out / "rollouts.npz")
    metrics = report_for(env_id)(table, env, policy, out, args.episodes, seed, make_env)
    add_collisions(metrics, table, out)
    # how far each rate may move on another block of episodes: 95 % half-widths, episodes as clusters
    metrics["intervals_95"] = {name: i["half_width"] for name, i in
                               rate_intervals(table, tuple(r for r in RATES if r in metrics)).items()}
    metrics.update(source)
    metrics.update(episodes=args.episodes, seed=seed, seed_set=REPORT.name, deterministic=not args.stochastic,
                   env_id=env_id, env_config={
                       "num_cars": env.config.num_cars, "lidar_noise": env.config.lidar_noise,
                       "remove_collided": env.config.remove_collided},
                   eval_seconds=round(seconds, 2))
    if run_dir is not None and (run_dir / "state.json").exists():
        metrics["training"] = json.loads((run_dir / "state.json").read_text())
    (out / "metrics.json").write_text(json.dumps(metrics, indent=2))

    progress = None
    if run_dir is not None:  # a bilevel run keeps the acceleration stage's logs in accel/
        progress = plots.read_progress(run_dir) or plots.read_progress(run_dir / "accel")
    if progress is not None:
        mark = metrics.get("training", {}).get("agent_steps")
        plots.learning_curves(progress, out / "learning_curves.png", mark)
    if args.video > 0:
        from box2d_driving.render.video import record

        drawn: dict[str, Any] = {"render_mode": "rgb_array"}  # the evaluated settings, drawn
        if args.checkpoint not in SCRIPTED and metrics.get("stop_value") in (0.0, 1.0):
            # a trained policy: the value it stopped on in these episodes is drawn red
            drawn["render_stop_value"] = float(metrics["stop_value"])
        video_env = make_env(**drawn)
        record(video_env, policy, episodes=args.video, video=out / "episodes.mp4", seed=seed)
    return metrics


def main(argv: Optional[list[str]] = None) -> int:
    args = parse(Args, argv, description=__doc__.split("\n\n")[0])
    try:
        metrics = evaluate(args)
    except (FileExistsError, FileNotFoundError, ValueError) as exc:
        return error(str(exc))
    print(json.dumps({k: v for k, v in metrics.items() if not isinstance(v, dict)}, indent=2))
    print(f"report: {Path(args.out) / 'metrics.json'}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
