"""The paper's own trainer's runs and scripted drivers carried in ``assets/original/``, as the
results page reads them.

``box2d-driving original train`` writes a run folder (``run.json``, ``state.json``, its log
``progress.csv``; ``original curve`` adds ``curve.csv``, ``original evaluate --run`` a
``report.json`` on report episodes); ``original evaluate --driver NAME --out
assets/original/drivers/NAME.json`` scores a scripted driver on the same episodes of the
original world. Nothing here judges a claim: :mod:`training.results.arbiter` (the noise claim)
and :mod:`training.results.lone_car_arbiter` (the lone car) do.
"""

from __future__ import annotations

import csv
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Optional

from training.results.data import ResultsError

__all__ = ["DRIVERS_FOLDER", "METRIC", "ORIGINAL_RUNS", "RULE_FREE", "DriverReport", "OriginalRun", "drivers_part",
           "finished", "load_driver_reports", "load_lone_car_runs", "load_original_runs", "rate_text", "report_rates",
           "same_episodes", "upper"]

ORIGINAL_RUNS = Path("assets/original")
METRIC = "red_light_violation_rate"
# scripted drivers' reports in the original world (``original evaluate --driver NAME``), under ORIGINAL_RUNS
DRIVERS_FOLDER = "drivers"
RULE_FREE = ("full-throttle", "random")  # drivers that never look at the light; "rule" follows it


@dataclass(frozen=True)
class OriginalRun:
    """One carried run of the original trainer and its report-episode evaluation (None: not
    evaluated yet)."""

    name: str
    lidar_noise: float
    seed: int
    epochs: int  # the original command's budget
    epochs_done: int
    joint_steps: int
    car_decisions: int
    report: Optional[dict[str, Any]]
    # per epoch, from the run's progress.csv: joint steps so far and the mean return of the episodes
    # that ended in it (the trainer's own log; empty where the run kept none)
    curve: tuple[tuple[int, float], ...] = field(default=(), compare=False)
    # per kept actor, from the run's curve.csv (``original curve``): joint steps and red-light
    # violations on selection episodes
    violations: tuple[tuple[int, float], ...] = field(default=(), compare=False)

    @property
    def evaluated_epochs(self) -> Optional[int]:
        return None if self.report is None else self.report.get("epochs")


def _is_noise_run(kwargs: dict[str, Any]) -> bool:
    """The noise claim's commands: the 4-car junction without turns."""
    return not kwargs.get("turns") and int(kwargs.get("nagents", 4)) == 4


def _is_lone_car_run(kwargs: dict[str, Any]) -> bool:
    """The 1-car run's command: one car on the turning junction (``original train --turns``)."""
    return bool(kwargs.get("turns")) and int(kwargs.get("nagents", 4)) == 1


def load_original_runs(folder: Path = ORIGINAL_RUNS) -> list[OriginalRun]:
    """Every run folder in ``folder`` (a ``run.json`` and a ``state.json``) of the noise claim's
    commands (the 4-car junction without turns; a run of the 1-car turning junction, ``original
    train --turns``, is not one: :func:`load_lone_car_runs`), by noise then seed;
    :class:`ResultsError` naming the file that cannot be read."""
    return _load_runs(folder, _is_noise_run)


def load_lone_car_runs(folder: Path = ORIGINAL_RUNS) -> list[OriginalRun]:
    """Every run folder in ``folder`` of the original's 1-car command (one car on its turning
    junction, ``original train --turns``), by seed."""
    return _load_runs(folder, _is_lone_car_run)


def _load_runs(folder: Path, keep: Callable[[dict[str, Any]], bool]) -> list[OriginalRun]:
    runs = []
    for run_json in sorted(Path(folder).glob("*/run.json")):
        here = run_json.parent
        try:
            spec = json.loads(run_json.read_text())
            if not keep(spec["env_kwargs"]):
                continue
            state = json.loads((here / "state.json").read_text())
            report_path = here / "report.json"
            report = json.loads(report_path.read_text()) if report_path.exists() else None
            runs.append(OriginalRun(here.name, float(spec["env_kwargs"]["lidar_noise"]), int(spec["seed"]),
                                    int(spec["epochs"]), int(state["epochs_done"]), int(state["joint_steps"]),
                                    int(state["car_decisions"]), report, _training_curve(here / "progress.csv"),
                                    _violations_curve(here / "curve.csv")))
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise ResultsError(f"{here}: not a readable original run ({exc})") from None
    return sorted(runs, key=lambda r: (r.lidar_noise, r.seed))


@dataclass(frozen=True)
class DriverReport:
    """A scripted driver scored on report episodes of the original world (``original evaluate
    --driver``): the reference a trained actor's red-light violations are read against."""

    driver: str
    cars: int  # per episode
    turns: bool
    episodes: int
    first_seed: int
    violations: float
    half_width: Optional[float]  # of the violations' 95 % interval, episodes as clusters


def load_driver_reports(folder: Path = ORIGINAL_RUNS) -> list[DriverReport]:
    """Every driver report in ``folder``/drivers/*.json, by name; :class:`ResultsError` naming a
    file that is not a scripted driver's report of the original world."""
    out = []
    for path in sorted((Path(folder) / DRIVERS_FOLDER).glob("*.json")):
        try:
            r = json.loads(path.read_text())
            if r.get("world") != "original" or not isinstance(r.get("driver"), str):
                raise ValueError("not a scripted driver in the original world")
            half = (r.get("intervals") or {}).get(METRIC, {}).get("half_width")
            out.append(DriverReport(r["driver"], int(r["cars_per_episode"]), bool(r["turns"]), int(r["episodes"]),
                                    int(r["first_seed"]), float(r[METRIC]), None if half is None else float(half)))
        except (OSError, ValueError, KeyError, TypeError, AttributeError) as exc:
            raise ResultsError(f"{path}: not a driver report of `original evaluate --driver` ({exc})") from None
    return out


def _training_curve(path: Path) -> tuple[tuple[int, float], ...]:
    """(joint steps so far, mean episode return) per epoch of a run's ``progress.csv``."""
    if not path.exists():
        return ()
    with path.open(newline="") as f:
        rows = list(csv.DictReader(f))
    out, steps = [], 0
    for r in rows:
        steps += int(r["joint_steps"])
        out.append((steps, float(r["episode_return"])))
    return tuple(out)


def _violations_curve(path: Path) -> tuple[tuple[int, float], ...]:
    """(joint steps, red-light violations) per kept actor of a run's ``curve.csv``."""
    if not path.exists():
        return ()
    with path.open(newline="") as f:
        return tuple((int(r["joint_steps"]), float(r[METRIC])) for r in csv.DictReader(f))


def finished(runs: list[OriginalRun]) -> list[OriginalRun]:
    """The runs that finished their command's budget and were evaluated at its last epoch."""
    return [r for r in runs if r.report is not None and r.epochs_done == r.epochs and r.evaluated_epochs == r.epochs]


def upper(run: OriginalRun) -> float:
    """The upper end of a run's violations' interval over its report episodes (the rate itself
    where the report has no interval)."""
    report = run.report or {}
    half = (report.get("intervals") or {}).get(METRIC, {}).get("half_width")
    return float(report[METRIC]) + (half or 0.0)


def report_rates(run: OriginalRun) -> list[str]:
    """A run's red-light violations, success and collisions on its report episodes as the page's
    tables write them (each with its interval where the report has one)."""
    if run.report is None:
        return ["not evaluated"] * 3
    half = {k: v.get("half_width") for k, v in (run.report.get("intervals") or {}).items()}
    return [f"{run.report[k]:.3f}" + (f" ± {half[k]:.3f}" if half.get(k) is not None else "")
            for k in (METRIC, "success_rate", "collision_rate")]


def rate_text(d: DriverReport) -> str:
    """A driver's violations as the page writes them, with their interval where known."""
    return f"{d.violations:.3f}" + ("" if d.half_width is None else f" ± {d.half_width:.3f}")


def same_episodes(runs: list[OriginalRun], drivers: list[DriverReport], cars: int,
                  turns: bool) -> tuple[int, list[DriverReport]]:
    """(episodes, drivers): the drivers of the world of ``cars`` cars (``turns``: the turning
    junction) scored on the very report episodes every evaluated run was; (0, []) where the runs
    disagree on their episodes or none was evaluated."""
    episodes = {(int(report.get("first_seed", -1)), int(report.get("episodes", -1)))
                for report in (r.report for r in runs) if report is not None}
    if len(episodes) != 1:
        return 0, []
    first, count = episodes.pop()
    return count, [d for d in drivers if d.cars == cars and d.turns == turns and (d.first_seed, d.episodes) ==
                   (first, count)]


def drivers_part(runs: list[OriginalRun], drivers: list[DriverReport], cars: int, turns: bool,
                 all_below: str) -> list[str]:
    """The scripted drivers of the runs' world (``cars``, ``turns``) on the same report episodes
    as the evaluated runs, and how many finished runs enter on red less than every rule-free
    driver (the run's interval over its episodes below the lowest rule-free rate; ``all_below``
    said where all do); empty where no driver was scored on those episodes."""
    count, here = same_episodes(runs, drivers, cars, turns)
    if not here:
        return []
    free = [d for d in here if d.driver in RULE_FREE]
    others = [d for d in here if d.driver not in RULE_FREE]
    words = "; ".join([", ".join(f"{d.driver} {rate_text(d)}" for d in free)]
                      + ([f"for comparison, the scripted light rule (brakes while its light shows yellow or red, "
                          f"else full throttle) {', '.join(rate_text(d) for d in others)}"] if others else []))
    flags = (f" --cars {cars}" if cars != (1 if turns else 4) else "") + (" --turns" if turns else "")
    line = (f"**Scripted drivers on the same {count} report episodes of the original world** (red-light violations; "
            f"`box2d-driving original evaluate --driver NAME{flags} --out {ORIGINAL_RUNS.as_posix()}/"
            f"{DRIVERS_FOLDER}/NAME{'-turns' if turns else ''}.json`): {words}.")
    done = finished(runs)
    if free and done:
        lowest = min(d.violations for d in free)
        below = [r for r in done if upper(r) < lowest]
        line += (f" {len(below)} of the {len(done)} finished runs enter on red less than every rule-free driver "
                 f"(their interval's upper end below {lowest:.3f})"
                 + (f": {all_below}." if len(below) == len(done) else "."))
    return [line, ""]
