"""``box2d-driving original``: the paper's own simulator and trainer (sdriving 0.1.0), run beside ours.

* ``original setup``: builds a separate virtual environment with sdriving 0.1.0 from the package
  registry (its own old ``gym`` and ``torch``; nothing of it enters ours);
* ``original train --lidar-noise P --seed S --out DIR``: the original command for that noise
  level (:mod:`training.original.commands`), run by sdriving's own ``ppo_distributed`` trainer in
  one process (``sdriving_worker.py``); ``--time-limit`` stops after the last epoch that fits, and
  ``--resume`` continues a folder from its last epoch;
* ``original evaluate --run DIR`` (or ``--policy P``, one of ours, or ``--driver NAME``, a scripted
  driver): a policy on report episodes of either world (``--world original | ours``), scored by
  our metric code;
* ``original both-worlds --policy P ... | --run DIR ...``: several policies in both worlds on the
  same report episodes, and all of them together (``both_worlds.py``);
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
from training.original.commands import NOISE_EPOCHS, OriginalError, OriginalRun, lone_car_run
from training.original.compare import DRIVERS
from training.original.out_folder import check_settings
from training.original.tables import (WORKER, driver_table, policy_source, require_venv, run_weights, score_table,
                                      trained_original_table, venv_dir, venv_python, write_table)

# what the worker's environment installs: sdriving without its training-only dependencies, and
# what its trainer and our worker import
PACKAGES = ("torch==2.13.0", "numpy", "scipy", "gym", "matplotlib", "celluloid", "joblib", "pandas",
            "safetensors")


DESCRIPTION = ("The paper's own simulator and trainer (sdriving 0.1.0) beside ours: `setup` builds its "
               "environment, `train` runs an original command (resumable).")


def check_report_episodes(episodes: int, first_seed: int) -> None:
    """``--episodes`` report episodes from ``--first-seed``, all in the report range."""
    if episodes < 1:
        raise OriginalError(f"--episodes must be >= 1, got {episodes}")
    REPORT.episodes(episodes, first_seed)


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
    return (preset or "default") + ("" if cars == 4 else f"-{cars}car{'' if cars == 1 else 's'}")


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


def _evaluate(args) -> int:
    from box2d_driving.cli import _parse_overrides
    from box2d_driving.metrics.rollouts import load_table

    table_path = args.out.with_suffix(".npz")
    try:
        check_report_episodes(args.episodes, args.first_seed)
        overrides = _parse_overrides(args.set)
        if overrides and args.world != "ours":
            raise OriginalError("--set changes our world's settings: it needs --world ours")
        weights, original = None, None
        cars = _driver_world(args)
        if args.run is not None:
            weights = run_weights(args.run, args.epoch)
        elif args.epoch is not None:
            raise OriginalError("--epoch picks an actor of an original run (--run), not of --policy")
        elif args.policy is not None and args.world == "original":  # a policy of ours: refused here, before
            # anything is written, if the original cannot run it
            original = policy_source(args.policy)
        for path in (args.out, table_path):
            if path.exists():
                raise OriginalError(f"--out: {path} exists (choose another name)")
        if args.world == "original":
            require_venv()
        args.out.parent.mkdir(parents=True, exist_ok=True)
        if args.driver is not None:
            driver_table(table_path, args.driver, args.world, args.episodes, args.first_seed, cars, args.turns,
                         overrides)
        else:
            write_table(table_path, args.world, args.episodes, args.first_seed, run=args.run, weights=weights,
                        epoch=args.epoch, policy=args.policy, original=original, overrides=overrides)
    except (OriginalError, SeedError, OSError, ValueError) as exc:  # CheckpointError is a ValueError
        return error(str(exc))
    metrics = score_table(load_table(table_path))
    metrics.update(episodes=args.episodes, first_seed=args.first_seed, world=args.world, overrides=overrides)
    if args.run is not None and weights is not None:
        state = json.loads((args.run / "state.json").read_text()) if (args.run / "state.json").exists() else {}
        latest = args.epoch is None
        # the weights named within the run folder: a report travels with its run (carried, copied)
        metrics.update(run=args.run.name, epochs=state.get("epochs_done") if latest else args.epoch,
                       weights=weights.relative_to(args.run).as_posix(),
                       joint_steps=state.get("joint_steps") if latest else None,
                       car_decisions=state.get("car_decisions") if latest else None)
    elif args.driver is not None:
        metrics.update(driver=args.driver, cars_per_episode=cars, turns=args.turns)
    else:
        metrics.update(policy=str(args.policy))
    tmp_out = args.out.with_name(args.out.name + ".partial")
    tmp_out.write_text(json.dumps(metrics, indent=1, default=float) + "\n")
    os.replace(tmp_out, args.out)
    print(json.dumps({k: v for k, v in metrics.items() if not isinstance(v, dict)}, default=float))
    return 0


def _driver_world(args) -> int:
    """The cars of a scripted driver's world (``--cars``; default 1 with ``--turns``, else the noise
    runs' 4); :class:`OriginalError` where ``--cars`` or ``--turns`` come without ``--driver``
    (a run or policy brings its own world)."""
    if args.driver is None:
        if args.cars is not None or args.turns:
            raise OriginalError("--cars and --turns choose a scripted driver's world: they need --driver")
        return 0
    if args.epoch is not None:
        raise OriginalError("--epoch picks an actor of an original run (--run), not of --driver")
    cars = args.cars if args.cars is not None else (1 if args.turns else 4)
    OriginalRun(lidar_noise=0.0, epochs=1, nagents=cars, turns=args.turns)  # refuses a count the original lacks
    return cars


def _both_worlds(args) -> int:
    from box2d_driving.cli import _parse_overrides
    from training.original import both_worlds as bw

    try:
        check_report_episodes(args.episodes, args.first_seed)
        overrides = _parse_overrides(args.set)
        found = bw.drivers(args.run, args.policy)
        require_venv()
        check_settings(args.out, {"episodes": args.episodes, "first_seed": args.first_seed,
                                     "overrides": overrides})
        bw.drive(args.out, found, args.episodes, args.first_seed, overrides)
    except (OriginalError, SeedError, OSError, ValueError) as exc:  # CheckpointError is a ValueError
        return error(str(exc))
    result = bw.report(args.out, found)
    path = bw.write_report(args.out, result)
    print(bw.markdown(result))
    print(f"{path}: each policy and all together")
    return 0


def _export(args) -> int:
    from training.original.export import export_policy

    try:
        out = export_policy(args.run, run_weights(args.run, args.epoch), args.out, args.epoch)
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
    t.add_argument("--turns", action="store_true",
                   help="the original's 1-car run on its turning junction (1 car, horizon 20, entropy 1e-3, "
                        "60 epochs by default; its command has --lidar-noise 0)")
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
                   help="folder for the rollout tables (tables already there are read, not rerun; a folder "
                        "whose tables were drawn with other settings, in its settings.json, is refused)")
    c.add_argument("--page", type=Path, default=None,
                   help="also write the tables into this page's <!-- compare: NAME --> section (each driver's "
                        "table replaced, the other drivers' tables there kept)")
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
    who.add_argument("--driver", choices=DRIVERS,
                     help="a scripted driver (light-blind full throttle or constant speed, the light rule, uniform "
                          "random) in the noise runs' world at LiDAR noise 0 (--cars, --turns choose another): "
                          "the rule-free rates a trained policy is read against on the same episodes")
    e.add_argument("--cars", type=int, default=None,
                   help="with --driver: cars per episode (default: 4, 1 with --turns)")
    e.add_argument("--turns", action="store_true",
                   help="with --driver: the original's turning junction of its 1-car run (our side: paper-turns)")
    e.add_argument("--epoch", type=int, default=None,
                   help="score the actor kept after this epoch (actors/epoch_NNNN.safetensors; default: the latest)")
    e.add_argument("--episodes", type=int, default=200, help="report episodes (default: 200)")
    e.add_argument("--first-seed", type=int, default=REPORT.start,
                   help=f"first report seed (default: {REPORT.start})")
    e.add_argument("--out", type=Path, required=True,
                   help="metrics JSON to write (must not exist); the rollout table goes beside it (.npz)")
    e.add_argument("--world", choices=("original", "ours"), default="original",
                   help="drive the original's world (sdriving) or ours with the paper preset (paper-turns for "
                        "a --turns run), the actor renamed for the other's network where needed (default: original)")
    e.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="with --world ours: an override of our world's config, e.g. --set drive_on=right")
    b = sub.add_parser("both-worlds", help="trained policies in both worlds on the same report episodes, each "
                                           "and all together (original minus ours, with 95 %% intervals)")
    b.add_argument("--run", type=Path, nargs="+", default=[], help="original train run folders (each its last actor)")
    b.add_argument("--policy", type=Path, nargs="+", default=[],
                   help="policies of ours trained with the paper preset and the paper code's LiDAR encoder")
    b.add_argument("--episodes", type=int, default=200, help="report episodes per policy and world (default: 200)")
    b.add_argument("--first-seed", type=int, default=REPORT.start,
                   help=f"first report seed (default: {REPORT.start})")
    b.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                   help="an override of our world's config, e.g. --set integration=exact")
    b.add_argument("--out", type=Path, required=True,
                   help="folder for the tables and report.json (tables already there are read, not rerun)")
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
    if args.command == "both-worlds":
        return _both_worlds(args)
    if args.command == "curve":
        return _curve(args)
    if args.command == "compare":
        return _compare(args)
    try:
        run = OriginalRun(lidar_noise=args.lidar_noise, seed=args.seed, epochs=args.epochs,
                          **(lone_car_run() if args.turns else {}))
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
