"""``box2d-driving reproduce --run``: the paper's grid in one command.

Runs every rule's sweep (the commands on the results page, ``training/results/sections.py``) one
after the other on Ray Tune, each in ``RUNS/sweep-NAME``. A rule whose summary is already in the
summaries folder (``assets/sweeps/NAME.json`` in a checkout) continues from it: its finished trials
are taken as they are (``sweep --reuse``), so a fresh machine goes on where the committed results
stop. After each sweep its summary is copied back into that folder; the caller then rewrites the
page. Each trial lands as it finishes (:class:`~training.results.landing.TrialLander`): the
summary is copied then, and the trial's learning curve (every kept checkpoint, on selection
episodes) is merged into ``curves/NAME.csv`` beside it while the next trial trains, so a machine
that goes away mid-sweep loses only the trial in training. A sweep that stops before all its
trials finish (Ctrl-C, the machine going away) ends the run there: the same command continues it.
A trial stopped part-way (Ctrl-C) is carried: its curve so far is drawn and its resumable run
copied into ``carried/NAME/<trial>/`` in the summaries folder, so that the same command, on this
machine or a fresh one, continues it from there rather than from scratch. With a time limit
(``--time-limit``) the run stops itself that way once the limit has passed, and no later rule's
sweep starts. Each rule's sweep runs with the resources its command names (``--cpus-per-trial``,
which also sets the trials' torch threads, and ``--max-concurrent``) unless the caller overrides
them for every rule: the same threads give the same floating-point sums, so a continued rule
retraces the trials already on the page only under its own setting.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Optional, Sequence

from training.results.landing import TrialLander
from training.results.sections import Section

if TYPE_CHECKING:
    from training.sweeps.deadline import Deadline

__all__ = ["ReproduceError", "run_sections", "sweep_resources"]


class ReproduceError(ValueError):
    """A rule's sweep cannot start (Ray missing, a summary that belongs to another sweep)."""


# seconds between two looks at a running sweep for trials finished since (each lands then)
LAND_EVERY_S = 60.0


def sweep_resources(section: Section, cpus_per_trial: Optional[float] = None,
                    max_concurrent: Optional[int] = None) -> tuple[float, Optional[int]]:
    """CPU cores per trial and the most trials at once for ``section``'s sweep: the caller's values
    where given (``None``: not given), else those its command on the page names (its parser's
    defaults, 1 core and as many trials as resources allow, where it names none)."""
    args = section.args
    return (cpus_per_trial if cpus_per_trial is not None else args.cpus_per_trial,
            max_concurrent if max_concurrent is not None else args.max_concurrent)


def run_sections(sections: Sequence[Section], folder: Path, runs: Path, cpus_per_trial: Optional[float] = None,
                 gpus_per_trial: float = 0, max_concurrent: Optional[int] = None,
                 address: Optional[str] = None, deadline: Optional["Deadline"] = None) -> int:
    """Run (or continue) each section's sweep in turn; returns the exit status: 0 all trials done,
    1 a trial failed or a sweep was stopped before its end (the same call continues it).
    ``cpus_per_trial``, ``max_concurrent``: for every rule; ``None``: each rule's own
    (:func:`sweep_resources`).
    ``deadline``: past it, the sweep in progress stops as on Ctrl-C and no further one starts."""
    try:
        import ray  # noqa: F401
    except ImportError as exc:
        raise ReproduceError('--run needs Ray Tune: pip install -c constraints-cpu.txt -e ".[train,sweep]" '
                             f"({exc})") from None
    from training.sweeps.sweep import run_sweep
    from training.common.seeds import SELECTION
    from training.sweeps import curves
    from training.sweeps.spec import SweepError, check_spec
    from training.sweeps.carry import carried_folder, carried_runs
    from training.sweeps.summary import reusable_rows

    # check every rule before hours of training: its command, and that its summary is its own
    if deadline is not None:
        try:
            deadline.check_thread()
        except SweepError as exc:
            raise ReproduceError(str(exc)) from None
    plans = []
    for section in sections:
        summary = Path(folder) / f"{section.summary_name}.json"
        try:
            spec, threads = section.spec()
            check_spec(spec)
            if summary.exists():
                reusable_rows(summary, spec)
            carried_runs(carried_folder(folder, section.summary_name), spec)
        except SweepError as exc:
            raise ReproduceError(f"{section.key}: {exc}") from None
        plans.append((section, spec, threads, summary if summary.exists() else None))

    status = 0
    for section, spec, threads, reuse in plans:
        out = Path(runs) / section.out.name
        if deadline is not None and deadline.passed():
            print(f"== {section.title}: not started, --time-limit reached; run the same command again to go on",
                  flush=True)
            return 1
        cpus, concurrent = sweep_resources(section, cpus_per_trial, max_concurrent)
        print(f"== {section.title}: {section.command}" + (f" (continuing {reuse})" if reuse else ""), flush=True)
        # each trial lands as it finishes (summary and learning curve), while the next one trains
        lander = TrialLander(out, folder, section.summary_name, curves.SWEEP_CURVE_EPISODES, SELECTION.start,
                             log=lambda line: print(line, flush=True))
        lander.start(LAND_EVERY_S)
        try:
            rows = run_sweep(spec, out, cpus, gpus_per_trial, address, concurrent, reuse, threads,
                             carried=lander.carried_folder, deadline=deadline)
        except SweepError as exc:
            raise ReproduceError(f"{section.key}: {exc}") from None
        finally:
            lander.stop()
        lander.land()  # the final summary, and the curves of trials that finished since the last pass
        carried = lander.carry()  # trials stopped part-way travel with the summary
        if carried:
            print(f"== {section.title}: {len(carried)} trial(s) stopped part-way carried to {lander.carried_folder} "
                  "(commit it with the summary: the same command continues them on any machine)", flush=True)
        counts = {s: sum(r["status"] == s for r in rows) for s in ("done", "error", "stopped", "pending")}
        print(f"== {section.title}: {counts['done']} of {len(rows)} trials done"
              + "".join(f", {n} {s}" for s, n in counts.items() if s != "done" and n)
              + f"; summary {Path(folder) / (section.summary_name + '.json')}", flush=True)
        if counts["stopped"] or counts["pending"]:
            print("stopped before the end: run the same command again to continue", flush=True)
            return 1
        if counts["error"]:
            status = 1
    return status
