"""The sentences under each rule's table on the results page that say what was run: a trial's
budget in words and what it really ran, the paper's budget beside ours, where joined rows come
from and which finished trials the learning curves cover."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Optional

from training.results.data import Group, ResultsError
from training.original.commands import TrainerSettings
from training.results.sections import Section, section as section_by_key

__all__ = ["budget_note", "carried_line", "curve_coverage", "joined_note", "ran_budget", "ran_decisions",
           "trial_budget"]


def trial_budget(sweep: dict[str, Any]) -> str:
    """What one trial of ``sweep`` trains for, in words: its decisions, its bilevel rounds (the lanes and
    fast-lanes sweeps fix ``rounds``; a sweep over budgets has them in its table) or the behaviour's
    default, and the wall-clock cap if one was set."""
    in_grid = [(key, unit) for key, unit in (("timesteps", "decisions"), ("rounds", "bilevel rounds"))
               if key in sweep.get("grid", {})]
    if in_grid:
        budget = " and ".join(f"the {unit} in the table's `{key}` column" for key, unit in in_grid)
    elif sweep.get("timesteps"):
        budget = f"{sweep['timesteps']:,} decisions"
    elif sweep.get("fixed", {}).get("original_epochs"):
        epochs = int(sweep["fixed"]["original_epochs"])
        epoch = TrainerSettings.steps_per_epoch
        budget = f"{epochs} epochs of {epoch:,} joint steps ({epochs * epoch / 1e6:g} M joint steps)"
    elif sweep.get("fixed", {}).get("rounds"):
        budget = f"{sweep['fixed']['rounds']} bilevel rounds"
    else:
        budget = "the behaviour's default budget"
    return budget + (f" (at most {sweep['minutes']:g} min)" if sweep.get("minutes") else "")


def budget_note(section: Section, curves: bool = False) -> str:
    """The paper's budget beside ours, and what is known of whether the metric had stopped
    moving at ours: measured where the sweep's learning curves on selection seeds are committed
    (``curves``), else not."""
    paper = f" **Budget.** The paper's runs: {section.paper_budget}." if section.paper_budget else \
        " **Budget.** The paper's budget for this rule is not known to us."
    if curves:
        return paper + (" Whether each metric had stopped moving at our budget: the learning curves below, every "
                        "checkpoint on selection episodes (`box2d-driving curve`).")
    return paper + (" Whether the metric had stopped moving at our budget is not measured (the sweep's checkpoints "
                    "were not kept for a learning curve).")


def joined_note(section: Section, paths: list[str], joined: list[Group]) -> str:
    """Where the table's rows from ``section.joins`` (``joined``) come from (``paths``: their summaries)."""
    if not paths:
        return ""
    assert section.joins is not None  # only sections that join another have joined rows
    key, option = section.joins
    title = section_by_key(key).title
    values = ", ".join(dict.fromkeys(g.point[option] for g in joined))
    return (f" The rows at `{option}` {values} come from \"{title}\" (summary "
            f"{', '.join(f'`{p}`' for p in paths)}): the same settings and training seeds at that `{option}`, "
            "so levels are compared paired by seed; their learning curves are drawn there.")


def curve_coverage(curves: list[dict[str, Any]], trials: list[dict[str, Any]], keys: list[str]) -> str:
    """Which finished trials the learning curves cover, where not all of them: a trial taken from a
    summary committed on another machine has no checkpoints here to draw. A trial is its grid point
    (``keys``) and seed."""
    def ident(r: dict[str, Any]) -> tuple:
        return (*(str(r.get(k)) for k in keys), int(r["seed"]))

    drawn = {ident(r) for r in curves}
    done = [r for r in trials if r.get("status") == "done"]
    covered = [r["trial"] for r in done if ident(r) in drawn]
    if len(covered) == len(done):
        return ""
    return (f"; {len(covered)} of the {len(done)} finished trials ({', '.join(covered)}): the others "
            "ran where their checkpoints were not kept")


def ran_decisions(trials: list[dict[str, Any]]) -> list[int]:
    """The decisions each finished trial trained (trials without a number left out)."""
    return [int(r["decisions"]) for r in trials
            if r.get("status") == "done" and isinstance(r.get("decisions"), (int, float))]


def ran_budget(trials: list[dict[str, Any]]) -> str:
    """What the finished trials really trained, in decisions: a trial stops at the end of the
    rollout that passes its budget, so it runs a little past what was asked."""
    ran = sorted(set(ran_decisions(trials)))
    if not ran:
        return ""
    ran_text = f"{ran[0]:,}" if len(ran) == 1 else f"{ran[0]:,} to {ran[-1]:,}"
    return f" (each ran {ran_text} decisions: whole rollouts)"


def carried_line(summary: dict[str, Any], command: Optional[str] = None) -> Optional[str]:
    """The trials of ``summary`` stopped part-way and carried beside it (``carried/NAME/<trial>/``,
    not yet in its table): how far each got in decisions, from its ``state.json``, against the budget
    its ``config.json`` asks for, and ``command``, which continues them; None where none is carried.
    :class:`ResultsError` names a carried run whose files cannot be read."""
    from training.sweeps.carry import carried_folder, carried_trials

    path = Path(summary["path"])
    folder = carried_folder(path.parent, path.stem)
    if not folder.is_dir():
        return None
    done = {r["trial"] for r in summary["trials"] if r.get("status") == "done"}
    found = []
    # a finished trial's carry is removed when it lands; one left beside a committed summary is not part-way
    for run in (r for r in carried_trials(folder) if r.name not in done):
        try:
            ran = int(json.loads((run / "state.json").read_text())["decisions"])
            asked = json.loads((run / "config.json").read_text()).get("timesteps")
        except (OSError, ValueError, KeyError, TypeError) as exc:
            raise ResultsError(f"{run}: a carried run without a readable state.json and config.json ({exc})") from exc
        of = f" of {int(asked):,} ({100 * ran / int(asked):.0f} %)" if isinstance(asked, (int, float)) and asked else ""
        found.append(f"`{run.name}` at {ran:,}{of} decisions")
    if not found:
        return None
    return (f"Carried part-way, not in the table (`{folder.as_posix()}/`: each trial's latest checkpoint with its "
            "optimiser state): " + ", ".join(found) + "."
            + (f" `{command}` continues them." if command else ""))
