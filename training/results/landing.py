"""Landing a sweep trial by trial while it runs (``box2d-driving reproduce --run``).

A rule's sweep may run for many hours, longer than the machine it runs on may stay up. So that
what finished is never lost with the machine, :class:`TrialLander` watches the sweep folder while
Ray Tune trains: each time a trial finishes, the sweep's summary is copied into the summaries
folder (``assets/sweeps/NAME.json`` and ``.csv``; only its finished and failed trials: those not
started yet, and those stopped part-way when the sweep was interrupted, are left out, so a summary
committed mid-sweep holds no empty rows and no row that the next run of the sweep replaces) and
that trial's learning curve (every kept checkpoint on selection episodes) is drawn and merged
into ``curves/NAME.csv``, and its final actor weights are kept in ``weights/NAME/<trial>/``
(:mod:`training.sweeps.kept`), while the next trial trains. A trial whose curve the curves file
already holds, drawn from the same checkpoints on the same episodes, is not drawn again.

When the sweep stops with trials part-way (Ctrl-C, the session's time running out),
:meth:`TrialLander.carry` lets them travel with the summaries: each stopped trial's curve so far
is drawn into the curves file and its resumable run (:mod:`training.sweeps.carry`) copied to
``carried/NAME/<trial>/``, where the next ``reproduce --run``, on any machine, continues it. The
carried run is removed once its trial lands.
"""

from __future__ import annotations

import json
import shutil
import threading
from pathlib import Path
from typing import Callable, Optional

from training.evaluation.checkpoint_curve import CurveError
from training.sweeps.summary import write_summary_files

__all__ = ["LANDED", "TrialLander"]

LANDED = ("done", "error")  # the trial statuses a landed summary keeps


class TrialLander:
    """Copies the summary of the sweep in ``out`` to ``folder/NAME.json|csv`` and merges each
    finished trial's learning curve into ``folder/curves/NAME.csv``.

    :meth:`land` does one pass (the caller's thread); :meth:`start` repeats it every
    ``every_s`` seconds in a background thread until :meth:`stop`. Curves are drawn on
    ``episodes`` selection episodes from ``seed``."""

    def __init__(self, out: Path, folder: Path, name: str, episodes: int, seed: int,
                 log: Callable[[str], None] = print) -> None:
        self.out, self.folder, self.name = Path(out), Path(folder), name
        self.episodes, self.seed, self.log = episodes, seed, log
        self.drawn: set[str] = set()  # trials landed by this lander (or found already drawn)
        self._stop = threading.Event()
        self._thread: Optional[threading.Thread] = None

    @property
    def curves_path(self) -> Path:
        return self.folder / "curves" / f"{self.name}.csv"

    def copy_summary(self) -> bool:
        """The sweep's summary into the summaries folder, its finished (``done``) and failed
        (``error``) trials only; False when the sweep has no summary yet. Pending trials (not
        started) and stopped ones (interrupted part-way: the next run of the sweep continues them
        from their run folder, which a committed summary does not carry) have no result to keep."""
        if not (self.out / "summary.json").exists():
            return False
        saved = json.loads((self.out / "summary.json").read_text())
        self.folder.mkdir(parents=True, exist_ok=True)
        write_summary_files(self.folder, self.name, saved["sweep"],
                            [r for r in saved["trials"] if r.get("status") in LANDED])
        return True

    def land(self) -> list[str]:
        """One pass: the summary copied, and the curve of every trial finished (by the summary)
        since the last pass whose run folder is here; returns the trials whose curves it drew.
        A trial taken from a committed summary has no run folder here and keeps its rows. A
        finished trial's carried run, if any, is removed: the trial has landed."""
        from training.sweeps import curves

        if not self.copy_summary():
            return []
        drawn = []
        for trial in curves.sweep_trials(self.out):
            name = trial["trial"]
            if name in self.drawn or not trial["done"]:
                continue
            if trial["run"].is_dir():
                if self._draw_missing(trial):
                    drawn.append(name)
                self._keep_weights(trial)
                self.drawn.add(name)
            # continued from a carried run, here or (a summary committed with its carry left
            # behind) elsewhere: the carry is stale now
            if (self.carried_folder / name).is_dir():
                shutil.rmtree(self.carried_folder / name)
        return drawn

    def _keep_weights(self, trial: dict) -> None:
        """The finished trial's final actor weights into ``weights/NAME/<trial>/`` (once)."""
        from training.sweeps.kept import keep_final_weights, kept_folder

        dest = kept_folder(self.folder, self.name) / trial["trial"]
        if not (dest / "config.json").exists() and not (dest / "accel").exists():
            keep_final_weights(trial["run"], dest)

    @property
    def carried_folder(self) -> Path:
        from training.sweeps.carry import carried_folder

        return carried_folder(self.folder, self.name)

    def _draw_missing(self, trial: dict) -> bool:
        """Draw the trial's kept checkpoints the curves file has no row of (on these episodes)
        and merge them in; False when there were none."""
        from training.sweeps import curves

        skip = curves.drawn_decisions(self.curves_path, trial["trial"], self.episodes, self.seed)
        if curves.drawn_already(self.curves_path, trial, self.episodes, self.seed, drawn=skip):
            return False
        curves.merge_curves(self.curves_path,
                            curves.trial_curve_rows(trial, self.episodes, self.seed, log=self.log, skip=skip))
        return True

    def carry(self) -> list[str]:
        """After the sweep stopped: for every trial stopped part-way with a checkpoint here, draw
        its curve so far into the curves file and copy its resumable run to
        ``carried/NAME/<trial>/`` (replacing an earlier carry of it); returns those trials."""
        from training.sweeps import curves
        from training.sweeps.carry import carry_run

        if not (self.out / "summary.json").exists():
            return []
        carried = []
        for trial in curves.sweep_trials(self.out):
            if trial["status"] != "stopped" or not (trial["run"] / "state.json").exists():
                continue  # stopped before its first checkpoint: it starts over, nothing to carry
            try:
                self._draw_missing(trial)
            except CurveError as exc:  # no kept checkpoint yet: the run still travels
                self.log(f"{trial['trial']}: no curve drawn before carrying it ({exc})")
            carry_run(trial["run"], self.carried_folder / trial["trial"])
            carried.append(trial["trial"])
        return carried

    def _watch(self, every_s: float) -> None:
        import torch

        torch.set_num_threads(1)  # the curves share the machine with the trial training beside them
        while not self._stop.wait(every_s):
            try:
                self.land()
            except (CurveError, OSError, ValueError) as exc:  # the sweep goes on; the final pass retries
                self.log(f"landing {self.name}: {exc} (tried again at the end of the sweep)")

    def start(self, every_s: float = 60.0) -> None:
        self._thread = threading.Thread(target=self._watch, args=(every_s,), name=f"land-{self.name}", daemon=True)
        self._thread.start()

    def stop(self) -> None:
        """Ends the background passes (after the curve being drawn, if any)."""
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
            self._thread = None
