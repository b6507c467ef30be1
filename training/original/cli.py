"""``box2d-driving original``: the paper's own simulator and trainer (sdriving 0.1.0), run beside ours.

* ``original setup``: builds a separate virtual environment with sdriving 0.1.0 from the package
  registry (its own old ``gym`` and ``torch``; nothing of it enters ours);
* ``original train --lidar-noise P --seed S --out DIR``: the original command for that noise
  level (:mod:`training.original.commands`), run by sdriving's own ``ppo_distributed`` trainer in
  one process (``sdriving_worker.py``); ``--time-limit`` stops after the last epoch that fits, and
  ``--resume`` continues a folder from its last epoch;
* ``original evaluate --run DIR`` (or ``--policy P``, one of ours): a policy on report episodes of
  either world (``--world original | ours``), scored by our metric code;
* ``original export --run DIR --out P``: a run's actor as a policy of ours (``export.py``);
* ``original curve --run DIR``: every actor the run kept, on the same selection episodes, one CSV
  row per epoch (a learning curve; selection seeds, since reading a curve is choosing).

The run folder holds ``run.json`` (the settings), ``weights.safetensors`` (actor, critic, Adam
states, torch's random state), ``state.json`` (epochs, joint steps, car-decisions) and
``progress.csv`` (one row per epoch).
"""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
import tempfile
from pathlib import Path
from typing import Optional, Sequence

from training.common.cli_args import OneLineParser, error, prog_name
from training.common.seeds import REPORT, SELECTION, SeedError
from training.original.commands import NOISE_EPOCHS, OriginalError, OriginalRun
from training.original.compare import DRIVERS

WORKER = Path(__file__).with_name("sdriving_worker.py")
# what the worker's environment installs: sdriving without its training-only dependencies, and
# what its trainer and our worker import
PACKAGES = ("torch==2.13.0", "numpy", "scipy", "gym", "matplotlib", "celluloid", "joblib", "pandas",
            "safetensors")


DESCRIPTION = ("The paper's own simulator and trainer (sdriving 0.1.0) beside ours: `setup` builds its "
               "environment, `train` runs an original command (resumable).")


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


def check_report_episodes(episodes: int, first_seed: int) -> None:
    """``--episodes`` report episodes from ``--first-seed``, all in the report range."""
    if episodes < 1:
        raise OriginalError(f"--episodes must be >= 1, got {episodes}")
    REPORT.episodes(episodes, first_seed)


def venv_python() -> Path:
    return venv_dir() / "bin" / "python"


def setup() -> int:
    target = venv_dir()
    if not venv_python().exists():
        subprocess.run([sys.executable, "-m", "venv", str(target)], check=True)
    pip = [str(venv_python()), "-m", "pip", "install", "-q"]
    subprocess.run(pip + list(PACKAGES), check=True)
    subprocess.run(pip + ["--no-deps", "sdriving==0.1.0"], check=True)
    print(target)
    return 0


def prepare_folder(run: OriginalRun, out: Path, resume: bool) -> None:
    """Write ``run.json`` in a new folder, or check that a folder to resume holds this run."""
    spec_path = out / "run.json"
    if resume:
        if not spec_path.is_file():
            raise OriginalError(f"--resume: {spec_path} is missing (not an original-code run folder)")
        try:
            saved = json.loads(spec_path.read_text())
        except (OSError, ValueError) as exc:
            raise OriginalError(f"--resume: {spec_path} is unreadable ({exc})") from None
        if saved != run.spec():
            raise OriginalError(f"--resume: {spec_path} holds other settings than the ones given")
        return
    if out.exists() and (not out.is_dir() or any(out.iterdir())):
        raise OriginalError(f"--out {out} exists and is not an empty folder (--resume continues it)")
    out.mkdir(parents=True, exist_ok=True)
    tmp = spec_path.with_suffix(".json.partial")
    tmp.write_text(json.dumps(run.spec(), indent=1) + "\n")
    os.replace(tmp, spec_path)


def section_name(preset: str | None, cars: int) -> str:
    """The page section a comparison writes by default: the preset's name (``default`` without
    one), with ``-Ncars`` appended unless the cars are the noise runs' 4."""
    return (preset or "default") + ("" if cars == 4 else f"-{cars}cars")


def _compare(args) -> int:
    from box2d_driving.cli import _parse_overrides
    from box2d_driving.presets import preset_overrides
    from training.original.compare import compare, write_section

    try:
        check_report_episodes(args.episodes, args.first_seed)
        require_venv()
        overrides = _parse_overrides(args.set)
        if args.preset is not None:  # an unknown preset is refused before either world runs
            preset_overrides(args.preset, "intersection-v0")
        text = compare(venv_python(), WORKER, args.drivers, args.episodes, args.first_seed, args.cars, overrides,
                       args.out, args.preset)
        print(text)
        if args.page is not None:
            write_section(args.page, args.section or section_name(args.preset, args.cars), text)
    except (OriginalError, SeedError, ValueError, OSError) as exc:  # ConfigError is a ValueError
        return error(str(exc))
    return 0


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


CURVE_COLUMNS = ("epoch", "joint_steps", "episodes", "first_seed", "red_light_violation_rate", "success_rate",
                 "collision_rate")


def score_actor(run: Path, weights: Path, episodes: int, first_seed: int) -> dict:
    """:func:`score_table` of ``weights`` (a run's actor) driving the run's original world for
    ``episodes`` episodes from ``first_seed`` (sdriving's own environment, through the worker)."""
    from box2d_driving.metrics.rollouts import load_table

    with tempfile.TemporaryDirectory() as tmp:
        table = Path(tmp) / "rollouts.npz"
        trained_original_table(run / "run.json", weights, episodes, first_seed, table)
        return score_table(load_table(table))


def _curve(args) -> int:
    out = args.out or args.run / "curve.csv"
    try:
        if args.episodes < 1:
            raise OriginalError(f"--episodes must be >= 1, got {args.episodes}")
        SELECTION.episodes(args.episodes, args.first_seed)
        if not (args.run / "run.json").is_file():
            raise OriginalError(f"--run {args.run}: run.json is missing (not an original run folder)")
        actors = {int(p.stem.split("_")[1]): p for p in (args.run / "actors").glob("epoch_*.safetensors")}
        if not actors:
            raise OriginalError(f"--run {args.run}: no kept actors (actors/epoch_NNNN.safetensors)")
        rows = _curve_rows(out)
        other = [r for r in rows if (int(r["episodes"]), int(r["first_seed"])) != (args.episodes, args.first_seed)]
        if other:
            raise OriginalError(f"--out {out}: its rows were drawn on {other[0]['episodes']} episodes from seed "
                                f"{other[0]['first_seed']}; a curve keeps one set of episodes (choose another --out)")
        steps = int(json.loads((args.run / "run.json").read_text())["trainer"]["steps_per_epoch"])
        require_venv()
    except (OriginalError, SeedError, OSError, ValueError, KeyError) as exc:
        return error(str(exc))
    done = {int(r["epoch"]) for r in rows}
    for epoch in sorted(set(actors) - done):
        m = score_actor(args.run, actors[epoch], args.episodes, args.first_seed)
        rows.append({"epoch": epoch, "joint_steps": epoch * steps, "episodes": args.episodes,
                     "first_seed": args.first_seed, **{k: m[k] for k in CURVE_COLUMNS[4:]}})
        _write_curve(out, sorted(rows, key=lambda r: int(r["epoch"])))  # whole, after every actor: resumable
        print(f"epoch {epoch}: " + ", ".join(f"{k} {float(m[k]):.3f}" for k in CURVE_COLUMNS[4:]), flush=True)
    print(f"{out}: {len(rows)} epochs ({len(rows) - len(done)} new)")
    return 0


def _curve_rows(path: Path) -> list[dict]:
    if not path.exists():
        return []
    with path.open(newline="") as f:
        return list(csv.DictReader(f))


def _write_curve(path: Path, rows: list[dict]) -> None:
    tmp = path.with_name(path.name + ".partial")
    with tmp.open("w", newline="") as f:
        writer = csv.DictWriter(f, fieldnames=CURVE_COLUMNS)
        writer.writeheader()
        writer.writerows({k: r[k] for k in CURVE_COLUMNS} for r in rows)
    os.replace(tmp, path)


def _run_weights(run: Path, epoch: Optional[int]) -> Path:
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


def _policy_source(policy: Path) -> tuple[dict, dict]:
    """A policy of ours as the original's actor: (run.json for the worker, sdriving tensors)."""
    from box2d_driving.policies.checkpoint_file import find_config, read_arrays, read_json
    from box2d_driving.policies.shipped import resolve_policy_path
    from training.original.export import original_spec, to_original

    path, arrays, _ = read_arrays(resolve_policy_path(policy))  # policy arrays by state_dict name
    return original_spec(read_json(find_config(path))), to_original({f"policy/{k}": v for k, v in arrays.items()})


def _evaluate(args) -> int:
    from safetensors.numpy import save_file

    from box2d_driving.cli import _parse_overrides
    from box2d_driving.metrics.rollouts import load_table, save_table
    from training.original.export import export_policy

    table_path = args.out.with_suffix(".npz")
    try:
        check_report_episodes(args.episodes, args.first_seed)
        overrides = _parse_overrides(args.set)
        if overrides and args.world != "ours":
            raise OriginalError("--set changes our world's settings: it needs --world ours")
        if args.run is not None:
            weights = _run_weights(args.run, args.epoch)
        elif args.epoch is not None:
            raise OriginalError("--epoch picks an actor of an original run (--run), not of --policy")
        else:  # a policy of ours: refused here, before anything is written, if the original cannot run it
            spec, actor = _policy_source(args.policy) if args.world == "original" else ({}, {})
        for path in (args.out, table_path):
            if path.exists():
                raise OriginalError(f"--out: {path} exists (choose another name)")
        if args.world == "original":
            require_venv()
        args.out.parent.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryDirectory() as tmp:
            if args.run is not None and args.world == "original":
                trained_original_table(args.run / "run.json", weights, args.episodes, args.first_seed, table_path)
            elif args.run is not None:
                policy = export_policy(args.run, weights, Path(tmp) / "policy", args.epoch)
                save_table(trained_our_table(policy, args.episodes, args.first_seed, overrides), table_path)
            elif args.world == "original":
                (Path(tmp) / "run.json").write_text(json.dumps(spec))
                save_file(actor, str(Path(tmp) / "actor.safetensors"))
                trained_original_table(Path(tmp) / "run.json", Path(tmp) / "actor.safetensors", args.episodes,
                               args.first_seed, table_path)
            else:
                save_table(trained_our_table(args.policy, args.episodes, args.first_seed, overrides), table_path)
    except (OriginalError, SeedError, OSError, ValueError) as exc:  # CheckpointError is a ValueError
        return error(str(exc))
    metrics = score_table(load_table(table_path))
    metrics.update(episodes=args.episodes, first_seed=args.first_seed, world=args.world, overrides=overrides)
    if args.run is not None:
        state = json.loads((args.run / "state.json").read_text()) if (args.run / "state.json").exists() else {}
        latest = args.epoch is None
        # the weights named within the run folder: a report travels with its run (carried, copied)
        metrics.update(run=args.run.name, epochs=state.get("epochs_done") if latest else args.epoch,
                       weights=weights.relative_to(args.run).as_posix(),
                       joint_steps=state.get("joint_steps") if latest else None,
                       car_decisions=state.get("car_decisions") if latest else None)
    else:
        metrics.update(policy=str(args.policy))
    tmp_out = args.out.with_name(args.out.name + ".partial")
    tmp_out.write_text(json.dumps(metrics, indent=1, default=float) + "\n")
    os.replace(tmp_out, args.out)
    print(json.dumps({k: v for k, v in metrics.items() if not isinstance(v, dict)}, default=float))
    return 0


def _export(args) -> int:
    from training.original.export import export_policy

    try:
        out = export_policy(args.run, _run_weights(args.run, args.epoch), args.out, args.epoch)
    except (OriginalError, ValueError, OSError) as exc:
        return error(str(exc))
    print(f"{out}: the actor as our policy (box2d-driving evaluate --checkpoint {out})")
    return 0


def main(argv: Optional[Sequence[str]] = None) -> int:
    parser = OneLineParser(prog=prog_name(), description=DESCRIPTION)
    sub = parser.add_subparsers(dest="command", required=True)
    sub.add_parser("setup", help="build the sdriving 0.1.0 environment")
    t = sub.add_parser("train", help="run the original trainer on the original world")
    t.add_argument("--lidar-noise", type=float, required=True,
                   help=f"share of rays dropped; original commands exist for {', '.join(map(str, NOISE_EPOCHS))}")
    t.add_argument("--seed", type=int, default=0, help="training seed (default: 0)")
    t.add_argument("--epochs", type=int, default=None,
                   help="epochs of 32,000 joint steps (default: the original command's)")
    t.add_argument("--out", type=Path, required=True, help="run folder")
    t.add_argument("--resume", action="store_true", help="continue the run in --out")
    t.add_argument("--time-limit", type=float, default=None,
                   help="minutes; stops after the last epoch that fits (resume later)")
    c = sub.add_parser("compare", help="scripted drivers in both worlds, scored by one metric code")
    c.add_argument("--drivers", nargs="+", choices=DRIVERS, default=list(DRIVERS))
    c.add_argument("--episodes", type=int, default=1000, help="episodes per driver and world (default: 1000)")
    c.add_argument("--first-seed", type=int, default=REPORT.start,
                   help=f"first report seed (default: {REPORT.start})")
    c.add_argument("--cars", type=int, default=4, help="cars per episode (default: 4)")
    c.add_argument("--preset", default=None, help="our world's preset, e.g. paper (default: none, our defaults)")
    c.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="override of our intersection's config, e.g. --set horizon=25")
    c.add_argument("--out", type=Path, required=True,
                   help="folder for the rollout tables (tables already there are read, not rerun)")
    c.add_argument("--page", type=Path, default=None,
                   help="also write the tables into this page's <!-- compare: NAME --> section")
    c.add_argument("--section", default=None,
                   help="the page's section name (default: the preset's name, or 'default'; "
                        "'-Ncars' appended for N cars other than 4)")
    e = sub.add_parser("evaluate", help="an original-code run's policy, or one of ours, on report episodes of "
                                        "either world, scored by our metrics")
    who = e.add_mutually_exclusive_group(required=True)
    who.add_argument("--run", type=Path, help="an original train run folder (its actor)")
    who.add_argument("--policy", type=Path,
                     help="a policy of ours trained with the paper preset and the paper code's LiDAR encoder "
                          "(a run folder, a kept trial, a shipped name)")
    e.add_argument("--epoch", type=int, default=None,
                   help="score the actor kept after this epoch (actors/epoch_NNNN.safetensors; default: the latest)")
    e.add_argument("--episodes", type=int, default=200, help="report episodes (default: 200)")
    e.add_argument("--first-seed", type=int, default=REPORT.start,
                   help=f"first report seed (default: {REPORT.start})")
    e.add_argument("--out", type=Path, required=True,
                   help="metrics JSON to write (must not exist); the rollout table goes beside it (.npz)")
    e.add_argument("--world", choices=("original", "ours"), default="original",
                   help="drive the original's world (sdriving) or ours with the paper preset, the actor "
                        "renamed for the other's network where needed (default: original)")
    e.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="with --world ours: an override of our world's config, e.g. --set drive_on=right")
    x = sub.add_parser("export", help="an original-code run's actor as our policy (the paper preset's world)")
    x.add_argument("--run", type=Path, required=True, help="an original train run folder")
    x.add_argument("--epoch", type=int, default=None,
                   help="the actor kept after this epoch (default: the latest)")
    x.add_argument("--out", type=Path, required=True, help="policy folder to write (must not exist)")
    k = sub.add_parser("curve", help="every kept actor of a run on the same selection episodes (a learning curve)")
    k.add_argument("--run", type=Path, required=True, help="an original train run folder")
    k.add_argument("--episodes", type=int, default=100, help="selection episodes per actor (default: 100)")
    k.add_argument("--first-seed", type=int, default=SELECTION.start,
                   help=f"first selection seed (default: {SELECTION.start})")
    k.add_argument("--out", type=Path, default=None,
                   help="CSV to write; epochs already in it are kept, not redrawn (default: RUN/curve.csv)")
    args = parser.parse_args(argv)
    if args.command == "setup":
        return setup()
    if args.command == "evaluate":
        return _evaluate(args)
    if args.command == "export":
        return _export(args)
    if args.command == "curve":
        return _curve(args)
    if args.command == "compare":
        return _compare(args)
    try:
        run = OriginalRun(lidar_noise=args.lidar_noise, seed=args.seed, epochs=args.epochs)
        if args.time_limit is not None and not args.time_limit > 0:
            raise OriginalError(f"--time-limit must be a positive number of minutes, got {args.time_limit}")
        require_venv()
        prepare_folder(run, args.out, args.resume)
    except (OriginalError, OSError) as exc:
        return error(str(exc))
    cmd = [str(venv_python()), str(WORKER), "train", str(args.out)]
    if args.time_limit is not None:
        cmd += ["--time-limit", str(args.time_limit)]
    status = subprocess.run(cmd).returncode
    if status == 3:
        print(f"stopped at the time limit; continue with --resume --out {args.out}")
        return 0
    return status


if __name__ == "__main__":
    sys.exit(main())
