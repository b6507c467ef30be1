"""Stopping a sweep at a wall-clock deadline, as Ctrl-C would (``--time-limit MINUTES``).

A machine lent for a fixed time (a cluster job's wall time, a session's machine) is taken back
whether or not the sweep was stopped first, and a sweep killed outright keeps only its finished
trials. With a time limit the sweep stops itself in time: once the deadline passes, Ray Tune is
asked to end the run the way it ends one on Ctrl-C (it keeps the experiment's state, so the same
command continues it; ``reproduce --run`` then carries the trials stopped part-way,
:mod:`training.sweeps.carry`).

Ray Tune installs its stop handler on SIGUSR1 as well as on SIGINT while a run is under way, and on
SIGUSR1 even where ``TUNE_DISABLE_SIGINT_HANDLER`` is set, so the deadline sends SIGUSR1 to this
process. It does so only once Ray Tune's handler for the run in progress is installed: before
that, SIGUSR1 would end the process (its default action) or reach a handler left by an earlier
run (and be lost).
"""

from __future__ import annotations

import math
import os
import signal
import threading
import time
from contextlib import contextmanager
from dataclasses import dataclass
from typing import Iterator, Optional

from training.sweeps.spec import SweepError

__all__ = ["Deadline"]

STOP_SIGNAL = getattr(signal, "SIGUSR1", None)  # None on Windows: no --time-limit there


@dataclass
class Deadline:
    """A wall-clock deadline: ``end`` in :func:`time.monotonic` seconds. ``poll_s``: how often the
    watcher looks (seconds). ``fired``: whether it has asked Ray Tune to stop."""

    end: float
    poll_s: float = 1.0
    fired: bool = False

    @classmethod
    def after_minutes(cls, minutes: Optional[float], flag: str = "--time-limit") -> Optional["Deadline"]:
        """The deadline ``minutes`` from now (None for None); :class:`SweepError` names ``flag``
        for a limit that is not a positive number of minutes, or where this platform cannot
        signal a run to stop."""
        if minutes is None:
            return None
        if not (isinstance(minutes, (int, float)) and math.isfinite(minutes) and minutes > 0):
            raise SweepError(f"{flag}: {minutes!r} is not a positive number of minutes")
        if STOP_SIGNAL is None:
            raise SweepError(f"{flag}: needs SIGUSR1, which this platform lacks; stop the sweep with Ctrl-C")
        return cls(time.monotonic() + 60.0 * minutes)

    def left_s(self) -> float:
        """Seconds until the deadline (negative once it has passed)."""
        return self.end - time.monotonic()

    def passed(self) -> bool:
        return self.left_s() <= 0

    def check_thread(self) -> None:
        """:class:`SweepError` outside the main thread, where Ray Tune installs no stop handler (the
        limit would never stop the run). Callers check before writing anything (:func:`armed`
        checks again)."""
        if threading.current_thread() is not threading.main_thread():
            raise SweepError("--time-limit: the sweep must run in the main thread (only there does Ray Tune "
                             "install the stop handler the limit signals)")

    @contextmanager
    def armed(self) -> Iterator["Deadline"]:
        """Around one Ray Tune run (``tuner.fit()``, in the main thread): a watcher thread that,
        once the deadline has passed and Ray Tune's stop handler for this run is installed (the
        SIGUSR1 handler is no longer the one found here on entry), sends SIGUSR1 to this process
        once. The watcher ends when the block does. :class:`SweepError` outside the main thread
        (:meth:`check_thread`)."""
        self.check_thread()
        stop_signal = STOP_SIGNAL
        assert stop_signal is not None  # after_minutes refuses a platform without it
        before = signal.getsignal(stop_signal)
        done = threading.Event()

        def watch() -> None:
            # wake at the deadline, then every poll_s until Ray Tune's handler is there
            while not done.wait(self.poll_s if self.passed() else min(self.poll_s, self.left_s())):
                if self.passed() and signal.getsignal(stop_signal) is not before:
                    self.fired = True
                    os.kill(os.getpid(), stop_signal)
                    return

        watcher = threading.Thread(target=watch, name="sweep-deadline", daemon=True)
        watcher.start()
        try:
            yield self
        finally:
            done.set()
            watcher.join()
