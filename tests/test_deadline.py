"""``--time-limit``: the deadline that stops a sweep as Ctrl-C would, signalling Ray Tune only
once its stop handler for the run in progress is installed."""

from __future__ import annotations

import math
import signal
import time

import pytest

from tests.helpers import raised_in_a_thread
from training.sweeps.deadline import Deadline
from training.sweeps.spec import SweepError


@pytest.mark.parametrize("minutes", [0, -1, math.nan, math.inf, "5"])
def test_a_limit_that_is_not_a_positive_number_of_minutes_is_refused(minutes):
    with pytest.raises(SweepError, match="--time-limit: .* is not a positive number of minutes"):
        Deadline.after_minutes(minutes)


def test_no_limit_is_no_deadline_and_a_limit_counts_from_now():
    assert Deadline.after_minutes(None) is None
    d = Deadline.after_minutes(2)
    assert 119 < d.left_s() <= 120 and not d.passed()


def _stop_handler(calls):
    def handler(sig, frame):
        calls.append(sig)
    return handler


def test_the_deadline_signals_only_once_a_run_has_installed_its_stop_handler():
    """As Ray Tune does, the "run" installs its SIGUSR1 handler a moment after the block starts:
    the deadline, passed already, waits for it, then signals once."""
    original = signal.getsignal(signal.SIGUSR1)
    calls: list[int] = []
    try:
        signal.signal(signal.SIGUSR1, _stop_handler([]))  # a handler left by an earlier run: not this one's
        d = Deadline(time.monotonic() - 1.0, poll_s=0.05)
        with d.armed():
            time.sleep(0.3)
            assert calls == [] and not d.fired  # nothing sent to the earlier run's handler
            signal.signal(signal.SIGUSR1, _stop_handler(calls))  # this run starts
            for _ in range(100):
                if calls:
                    break
                time.sleep(0.02)  # the handler runs in this (the main) thread, between sleeps
            time.sleep(0.2)
        assert calls == [signal.SIGUSR1] and d.fired  # once
    finally:
        signal.signal(signal.SIGUSR1, original)


def test_a_run_that_ends_before_its_deadline_is_not_signalled():
    original = signal.getsignal(signal.SIGUSR1)
    calls: list[int] = []
    try:
        d = Deadline(time.monotonic() + 0.3, poll_s=0.05)
        with d.armed():
            signal.signal(signal.SIGUSR1, _stop_handler(calls))
            time.sleep(0.1)
        time.sleep(0.4)  # past the deadline, after the block: the watcher has gone
        assert calls == [] and not d.fired
    finally:
        signal.signal(signal.SIGUSR1, original)


def test_outside_the_main_thread_the_deadline_refuses_to_arm():
    """Ray Tune installs its stop handler only in the main thread: elsewhere a limit would never fire."""
    def arm() -> None:
        with Deadline(time.monotonic() + 60).armed():
            pass

    caught = raised_in_a_thread(arm)
    assert len(caught) == 1 and isinstance(caught[0], SweepError) and "main thread" in str(caught[0])


def test_a_sweep_outside_the_main_thread_refuses_its_limit_before_writing_anything(tmp_path):
    """The refusal comes before the sweep folder or Ray is started (programmatic callers in a
    worker thread), not after hours of setup."""
    from training.sweeps.spec import SweepSpec
    from training.sweeps.sweep import run_sweep

    out = tmp_path / "sweep"
    caught = raised_in_a_thread(
        lambda: run_sweep(SweepSpec("lights", timesteps=1000), out, deadline=Deadline(time.monotonic() + 60)))
    assert len(caught) == 1 and isinstance(caught[0], SweepError) and "main thread" in str(caught[0])
    assert not out.exists()
