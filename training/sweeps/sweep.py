"""Sweeps on Ray Tune: a grid of settings x training seeds, each trial an ordinary training run
followed by an evaluation on held-out report seeds.

    box2d-driving sweep lights --grid lidar_noise=0,0.25,0.5,0.75 num_cars=1,4,8 --seeds 3 \\
        --timesteps 991552 --out runs/sweep-lights
    box2d-driving sweep lights --grid lidar_noise=0,0.5 --seeds 2 --quick --out runs/sweep-quick

A trial runs the behaviour's own training script with ``--seed S``, the grid point and the fixed
``--set`` arguments as its command-line options (the same config dataclasses, the same run
folder), reports every checkpoint to Ray Tune together with the run folder, and ends with
``evaluate`` on report seeds. Rerunning the command with the same ``--out`` continues the sweep:
finished trials are not rerun, interrupted ones resume from their last checkpoint.

Output folder::

    OUT/sweep.json            the sweep's settings (a rerun must match them)
    OUT/tune/                 Ray Tune's experiment: one folder per trial with its results, its
                              TensorBoard logs and its latest checkpoint (checkpoint_NNNNNN/: a
                              complete run folder: evaluate, render or --resume it alone)
    OUT/summary.csv, .json    one row per trial: grid values, seed, status, every metric
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import shutil
import sys
from contextlib import nullcontext
from pathlib import Path
from typing import Any, Optional

from training.runs.run_dir import write_json_atomic
from training.sweeps.carry import carried_runs
from training.sweeps.deadline import Deadline
from training.sweeps.spec import (SweepError, SweepSpec, check_spec, parse_pairs, script_module,
                                 spec_differences)
from training.sweeps.summary import (extendable_runs, final_metrics, first_line, metrics_from_row, reusable_rows,
                                    summary_row, train_metrics, unreached_row, write_summary)

__all__ = ["SweepError", "SweepSpec", "main", "run_sweep", "run_trial"]

# the progress table ranks trials by their latest success rate: the training rollouts' while a
# trial trains, its report episodes' once it is evaluated
PROGRESS_METRIC = "success_rate"


# -- the trial (runs in a Ray worker) ----------------------------------------------------------
def trial_spec(config: dict[str, Any], trials: Optional[dict[str, dict]]) -> dict[str, Any]:
    """The trial's description: looked up by the name Ray Tune's config holds (sweeps started by
    an earlier release kept the whole description in the config)."""
    if "trial" in config:
        return config["trial"]
    if trials is None:
        raise SweepError(f"trial {config.get('name')!r}: no trial descriptions to look it up in")
    return trials[config["name"]]


def run_trial(config: dict[str, Any], trials: Optional[dict[str, dict]] = None) -> None:
    """Ray Tune function trainable: train (or resume from the trial's last checkpoint), reporting
    each checkpoint with the run folder, then evaluate on report seeds and report the metrics."""
    from ray import tune

    from training.sweeps.worker_exit import exit_on_ignored_system_exit

    exit_on_ignored_system_exit()  # Ray's SIGTERM at a stop: exit, not a traceback on the user's terminal
    from training.evaluation import evaluate  # noqa: F401  (imported now: a trial runs one version of the code,
    # even if the checkout changes while it trains)
    from training.common.cli_args import parse
    from training.behaviours.algorithms import algorithm_of

    trial = trial_spec(config, trials)
    if trial.get("reuse"):  # measured by an earlier run of this sweep (--reuse): its row as it was
        tune.report(metrics_from_row(trial["reuse"]))
        return
    script = script_module(trial["behaviour"])
    run = trial_run_folder()
    checkpoint = tune.get_checkpoint()
    if run.exists():  # left by an earlier attempt in this working folder: the checkpoint decides
        shutil.rmtree(run)
    if checkpoint is not None:
        with checkpoint.as_directory() as saved:
            shutil.copytree(saved, run)
    elif trial.get("carried"):  # stopped part-way on another machine (--carried): continued from there
        shutil.copytree(trial["carried"], run)
    elif trial.get("extend"):  # finished by a smaller-budget sweep (--extend): continued, not restarted
        start = Path(trial["extend"])
        shutil.copytree(start, run, ignore=lambda folder, names: ["eval"] if Path(folder) == start else [])
    resume = (run / "state.json").exists()
    eval_file = run / "eval" / "metrics.json"
    if eval_file.exists():  # finished before the sweep was stopped
        tune.report(final_metrics(run, json.loads(eval_file.read_text())))
        return

    def report(progress: dict[str, Any]) -> None:
        tune.report(train_metrics(progress), checkpoint=tune.Checkpoint.from_directory(str(run)))

    argv = trial["argv"] + ["--out", str(run)] + (["--resume"] if resume else [])
    algorithm = algorithm_of(script.Args)
    args = parse(script.Args, argv)
    result = algorithm.train(algorithm.config(script.ENV_ID, args), run, resume=resume, on_checkpoint=report)
    if "interrupted_by_signal" in result:
        raise RuntimeError(f"training stopped by signal {result['interrupted_by_signal']}; rerun the sweep")
    metrics = evaluate_run(run, trial["episodes"])
    tune.report(final_metrics(run, metrics), checkpoint=tune.Checkpoint.from_directory(str(run)))


def trial_run_folder() -> Path:
    """Where the running trial trains: ``run/`` in the working directory Ray Tune starts each trial
    in (``working_dirs/TRIAL`` of its session), which stays on this machine. Not in the trial's
    staging folder (``driver_artifacts/TRIAL``): the driver copies that one to the sweep folder
    every few minutes and on Ctrl-C, and a copy taken while the trainer replaced a checkpoint file
    failed (a file listed, then gone), printing a traceback. The sweep folder gets the run whole
    through each reported checkpoint (``tune/TRIAL/checkpoint_*``). Where Ray Tune was told not to
    change directory (``RAY_CHDIR_TO_TRIAL_DIR=0``), the staging folder it is."""
    from ray import tune

    here = Path.cwd()
    if str(here) != os.environ.get("TUNE_ORIG_WORKING_DIR"):  # moved to this trial's own directory
        return here / "run"
    return Path(tune.get_context().get_trial_dir()) / "run"


def evaluate_run(run: Path, episodes: int) -> dict[str, Any]:
    """The run's policy on the first ``episodes`` report seeds, written to ``run/eval``."""
    from training.evaluation.evaluate import Args, evaluate

    return evaluate(Args(checkpoint=str(run), episodes=episodes, out=str(run / "eval"), overwrite=True))


# -- the driver ------------------------------------------------------------------------------

try:  # Ray Tune is the sweep extra; without it the module still imports and says what to install
    from ray.tune import Callback as _TuneCallback
except ImportError:  # pragma: no cover - exercised by the no-Ray test
    _TuneCallback = object  # type: ignore[misc, assignment]  # a base class that is never used without Ray


class SummaryCallback(_TuneCallback):
    """Keeps summary.csv/json current as trials finish or fail (a killed sweep keeps them).

    A module-level class (not one made inside a function), so that a continued sweep, which
    restores its callbacks from Ray Tune's saved state, runs this code as it is now rather than a
    copy pickled when the sweep first started."""

    def __init__(self, out: Path, spec: SweepSpec, specs: dict[str, dict]):
        self.out, self.spec, self.specs = out, spec, specs

    def _write(self, trial, status: str, error: str = "") -> None:
        # merged into the summary on disk, which holds every earlier run of this sweep
        old = self.out / "summary.json"
        rows = {r["trial"]: r for r in json.loads(old.read_text())["trials"]} if old.exists() else {}
        metrics = trial.last_result or {}
        path = trial.checkpoint.path if trial.checkpoint is not None else ""
        row = summary_row(trial_spec(trial.config, self.specs), status, metrics, error, path)
        rows[row["trial"]] = row
        write_summary(self.out, self.spec, list(rows.values()))

    def on_trial_complete(self, iteration, trials, trial, **info) -> None:
        self._write(trial, "done")

    def on_trial_error(self, iteration, trials, trial, **info) -> None:
        try:  # the error's text, as Ray Tune stored it; its last line names the exception
            text = trial.get_error() or ""
        except Exception:
            text = ""
        self._write(trial, "error", first_line(str(text)) or "failed (see the trial's error.txt)")


def prepare_out(out: Path, spec: SweepSpec) -> bool:
    """Check ``out`` and write ``sweep.json``; True when an earlier run of this sweep is there."""
    saved = out / "sweep.json"
    if saved.exists():
        old = json.loads(saved.read_text())
        diff = spec_differences(old, spec)
        if diff:
            raise SweepError(f"{out} holds a different sweep ({', '.join(diff)} differ: "
                             f"{', '.join(f'{k}={old.get(k)!r}' for k in diff)}); choose another --out")
        return (out / "tune").exists()
    if out.exists() and any(out.iterdir()):
        raise SweepError(f"{out} exists, is not empty and holds no sweep; choose another --out")
    out.mkdir(parents=True, exist_ok=True)
    write_json_atomic(saved, dataclasses.asdict(spec))
    return False


CONCURRENCY_FILE = "concurrency.json"  # the --max-concurrent a sweep started with
EXTEND_FILE = "extends.json"  # the sweep folder whose trials this one continues (--extend)


def extended_sweep(out: Path, asked: Optional[Path]) -> Optional[Path]:
    """The sweep folder whose finished trials the sweep in ``out`` continues: the one ``--extend``
    names, kept in ``out`` so that a continued sweep keeps it without being told again.
    :class:`SweepError` when a continued sweep is asked to extend another folder."""
    saved_file = out / EXTEND_FILE
    saved = Path(json.loads(saved_file.read_text())["extends"]) if saved_file.exists() else None
    if asked is not None:
        asked = asked.resolve()
        if saved is not None and saved != asked:
            raise SweepError(f"{out} extends {saved}, not {asked}; choose another --out")
        if saved is None and (out / "tune").exists():
            raise SweepError(f"{out} began without --extend; choose another --out to extend {asked}")
    return saved or asked


def kept_concurrency(out: Path, asked: Optional[int]) -> str:
    """What a continued sweep in ``out`` says when ``asked`` differs from the ``--max-concurrent``
    it started with ('' if not): Ray Tune restores a sweep's search state, concurrency limit
    included, so a continued run keeps it (per-trial resources, by contrast, take the new values)."""
    try:
        started = json.loads((out / CONCURRENCY_FILE).read_text())["max_concurrent"]
    except (OSError, ValueError, KeyError, TypeError):
        return ""  # begun before this was recorded: nothing to compare
    if started == asked:
        return ""

    def shown(value: Optional[int]) -> str:
        return "(none)" if value is None else str(value)

    return (f"{out}: this sweep continues with the --max-concurrent it started with: {shown(started)} (asked: "
            f"{shown(asked)}); Ray Tune keeps a sweep's concurrency limit when it continues. To change it, start "
            f"a new sweep folder that reuses this one's summary (sweep --out NEW --reuse {out / 'summary.json'}, "
            f"or reproduce --run --runs NEW): finished trials are taken from the summary, unfinished ones start over.")


def run_sweep(spec: SweepSpec, out: Path, cpus_per_trial: float = 1, gpus_per_trial: float = 0,
              address: Optional[str] = None, max_concurrent: Optional[int] = None,
              reuse: Optional[Path] = None, threads: Optional[int] = None,
              extend: Optional[Path] = None, carried: Optional[Path] = None,
              deadline: Optional[Deadline] = None) -> list[dict[str, Any]]:
    """Run (or continue) the sweep in ``out``; returns the summary rows. Trials that ``reuse`` (a
    summary of this same sweep) lists as done are reported from it, not trained again. Trials
    that ``extend`` (a sweep folder of the same settings at a smaller budget) finished are
    continued from their last checkpoint to this sweep's budget instead of starting over. Trials
    with a run in ``carried`` (stopped part-way on another machine, :mod:`training.sweeps.carry`)
    continue from it when this folder holds no later checkpoint of theirs.
    ``threads``: torch threads per trial (default: the trial's CPU cores). ``deadline``: past it,
    the sweep stops as on Ctrl-C (:mod:`training.sweeps.deadline`)."""
    import ray
    from ray import tune

    check_spec(spec)
    if deadline is not None:  # refuse before any folder or Ray is started
        deadline.check_thread()
    if cpus_per_trial <= 0 or gpus_per_trial < 0:
        raise SweepError(f"--cpus-per-trial must be > 0 and --gpus-per-trial >= 0, "
                         f"got {cpus_per_trial} and {gpus_per_trial}")
    if max_concurrent is not None and max_concurrent < 1:  # Ray Tune reads 0 as "no limit"
        raise SweepError(f"--max-concurrent must be at least 1, got {max_concurrent}")
    out = Path(out).resolve()
    reused = reusable_rows(reuse, spec) if reuse is not None else {}
    extends = extended_sweep(out, extend)
    started = extendable_runs(extends, spec) if extends is not None else {}
    carried_here = carried_runs(carried, spec)
    restoring = prepare_out(out, spec)
    if extends is not None:
        write_json_atomic(out / EXTEND_FILE, {"extends": str(extends)})
        trials_word = "trial" if len(started) == 1 else "trials"
        print(f"--extend: {len(started)} finished {trials_word} of {extends} continue to this budget, "
              "the others start from scratch", file=sys.stderr)
    if not ray.is_initialized():
        if address:
            ray.init(address=address)
        else:  # this machine: trials queue when cores are few
            ray.init(num_cpus=max(os.cpu_count() or 1, math.ceil(cpus_per_trial)), include_dashboard=False,
                     object_store_memory=200 * 1024**2, configure_logging=False)
    trials = {t["name"]: t for t in spec.trials(("--threads", str(threads or max(1, int(cpus_per_trial)))))}
    for name, trial in trials.items():
        trial["reuse"] = reused.get(name)
        trial["extend"] = str(started[name]) if name in started else None
        trial["carried"] = str(carried_here[name].resolve()) if name in carried_here else None
    # Ray Tune's config holds only the trial's name (a short column in the progress table); the
    # descriptions reach the trials through the object store
    trainable = tune.with_resources(tune.with_parameters(run_trial, trials=trials),
                                    {"cpu": cpus_per_trial, "gpu": gpus_per_trial})
    if restoring and tune.Tuner.can_restore(str(out / "tune")):
        kept = kept_concurrency(out, max_concurrent)
        if kept:
            print(kept, file=sys.stderr)
        tuner = tune.Tuner.restore(str(out / "tune"), trainable, resume_unfinished=True, resume_errored=True)
    else:
        write_json_atomic(out / CONCURRENCY_FILE, {"max_concurrent": max_concurrent})
        tuner = tune.Tuner(
            trainable,
            param_space={"name": tune.grid_search(list(trials))},
            tune_config=tune.TuneConfig(metric=PROGRESS_METRIC, mode="max", max_concurrent_trials=max_concurrent,
                                        trial_name_creator=_trial_name, trial_dirname_creator=_trial_name),
            run_config=tune.RunConfig(
                name="tune", storage_path=str(out), failure_config=tune.FailureConfig(max_failures=0),
                checkpoint_config=tune.CheckpointConfig(num_to_keep=1),
                callbacks=[SummaryCallback(out, spec, trials)]),
        )
    with deadline.armed() if deadline is not None else nullcontext():
        results = tuner.fit()
    if deadline is not None and deadline.fired:
        print("--time-limit reached: the sweep stopped as on Ctrl-C (run the same command again to continue)",
              file=sys.stderr)
    rows = {}
    for result in (results[i] for i in range(len(results))):  # ResultGrid: indexable, not typed iterable
        if not result.config:  # a trial that never started (the sweep was stopped first)
            continue
        trial = trial_spec(result.config, trials)
        status = "error" if result.error else ("done" if (result.metrics or {}).get("done") else "stopped")
        path = result.checkpoint.path if result.checkpoint is not None else ""
        rows[trial["name"]] = summary_row(trial, status, result.metrics or {},
                                          first_line(result.error) if result.error else "", path)
    for name, trial in trials.items():
        if name not in rows:  # not reached before a stop
            rows[name] = unreached_row(trial)
    write_summary(out, spec, list(rows.values()))
    return list(rows.values())


def _trial_name(trial) -> str:
    return trial.config["name"] if "name" in trial.config else trial.config["trial"]["name"]


def build_parser():
    """The parser of ``box2d-driving sweep`` (behaviour, grid, seeds, budget, Ray resources, output)."""
    from training.common.cli_args import OneLineParser

    from box2d_driving.plugins import behaviours

    prog = sys.argv[0].rsplit("/", 1)[-1] if sys.argv[0].startswith("box2d-driving") else "box2d-driving sweep"
    p = OneLineParser(prog=prog,
               description="Train a grid of settings x training seeds on Ray Tune; every trial is "
                           "evaluated on held-out report seeds and summarised in OUT/summary.csv.")
    p.add_argument("behaviour", choices=behaviours(), help="what to train")
    p.add_argument("--grid", nargs="+", default=[], metavar="KEY=V1,V2",
                   help="training options to vary (names as the behaviour's --help lists them, "
                        "underscores or dashes), every combination runs")
    p.add_argument("--seeds", type=int, default=3, help="training seeds per grid point: 0..N-1 (default 3)")
    p.add_argument("--set", nargs="+", default=[], metavar="KEY=VALUE",
                   help="training options fixed for every trial, e.g. init_from=PATH batch_decisions=16000")
    p.add_argument("--timesteps", type=int, help="slot-decisions per trial (default: the behaviour's)")
    p.add_argument("--minutes", type=float, help="wall-clock minutes per trial")
    p.add_argument("--episodes", type=int, default=200, help="report episodes per trial (default 200)")
    p.add_argument("--quick", action="store_true", help="short but real trials (each script's --quick)")
    p.add_argument("--cpus-per-trial", type=float, default=1,
                   help="CPU cores Ray reserves per trial; trials queue when all are taken (default 1)")
    p.add_argument("--gpus-per-trial", type=float, default=0, help="GPUs per trial, fractions allowed (default 0)")
    p.add_argument("--max-concurrent", type=int, help="at most this many trials at once (default: as resources allow)")
    p.add_argument("--address", help="a running Ray cluster (ray start --head ...; default: this machine)")
    p.add_argument("--reuse", metavar="SUMMARY_JSON",
                   help="a summary.json of this same sweep (e.g. committed from another machine): "
                        "its finished trials are taken as they are instead of being trained again")
    p.add_argument("--extend", metavar="SWEEP_FOLDER",
                   help="a sweep folder of the same settings at a smaller budget (--timesteps, or --set "
                        "rounds=N): its finished trials continue from their last checkpoint to this budget "
                        "instead of starting over (their runs must be on this machine)")
    p.add_argument("--carried", metavar="FOLDER",
                   help="run folders of trials stopped part-way on another machine, one per trial name "
                        "(see docs/sweeps.md): those trials continue from there instead of starting over")
    p.add_argument("--time-limit", type=float, metavar="MINUTES",
                   help="stop the sweep after this many minutes of wall-clock time, as Ctrl-C would (trials "
                        "in training keep their last checkpoint; the same command continues them): for a "
                        "machine lent for a fixed time")
    p.add_argument("--out", required=True, help="sweep folder; rerun with the same folder to continue")
    return p


def spec_from_args(args: Any) -> tuple[SweepSpec, Optional[int]]:
    """The sweep (and the torch threads per trial, not part of it) from parsed command-line
    arguments; :class:`SweepError` for a bad pair."""
    fixed = parse_pairs(args.set, "--set", many=False)
    threads = fixed.pop("threads", None)  # how fast, not what is learnt: not part of the sweep
    if threads is not None and (not threads.isdigit() or int(threads) < 1):
        raise SweepError(f"threads must be a whole number >= 1, got {threads!r}")
    spec = SweepSpec(behaviour=args.behaviour, grid=parse_pairs(args.grid, "--grid", many=True),
                     seeds=args.seeds, fixed=fixed, timesteps=args.timesteps, minutes=args.minutes,
                     episodes=args.episodes, quick=args.quick)
    return spec, int(threads) if threads else None


def main(argv: Optional[list[str]] = None) -> int:
    """Run (or continue) a sweep on Ray Tune, then write its summary; returns the exit status."""
    args = build_parser().parse_args(argv)
    prog = "box2d-driving sweep"
    try:
        import ray  # noqa: F401
    except ImportError as exc:
        print(f"{prog}: error: sweeps need Ray Tune: pip install -c constraints-cpu.txt -e \".[train,sweep]\" "
              f"({exc})", file=sys.stderr)
        return 2
    try:
        deadline = Deadline.after_minutes(args.time_limit)  # counted from the start of the command
        spec, threads = spec_from_args(args)
        rows = run_sweep(spec, Path(args.out), args.cpus_per_trial, args.gpus_per_trial, args.address,
                         args.max_concurrent, Path(args.reuse) if args.reuse else None, threads,
                         Path(args.extend) if args.extend else None, Path(args.carried) if args.carried else None,
                         deadline)
    except SweepError as exc:
        print(f"{prog}: error: {exc}", file=sys.stderr)
        return 2
    failed = [r for r in rows if r["status"] in ("error", "stopped")]
    pending = sum(r["status"] == "pending" for r in rows)
    done = sum(r["status"] == "done" for r in rows)
    print(f"{done} of {len(rows)} trials done" + (f", {pending} not started" if pending else "")
          + f"; summary: {Path(args.out) / 'summary.csv'} (run the same command again to continue)"
          if done < len(rows) else f"{done} of {len(rows)} trials done; summary: {Path(args.out) / 'summary.csv'}")
    for r in failed:
        print(f"  {r['trial']}: {r['status']}: {r['error']}", file=sys.stderr)
    return 1 if failed or pending else 0


if __name__ == "__main__":
    raise SystemExit(main())
