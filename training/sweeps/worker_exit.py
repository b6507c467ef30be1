"""A trial's Ray worker exits quietly when the sweep stops it.

When a sweep is stopped (Ctrl-C, ``--time-limit``), Ray ends each trial's worker with SIGTERM, and
the worker's handler raises ``SystemExit`` in whatever Python code its main thread is running.
If that happens to be a callback Python runs on its own (a weak-reference callback during garbage
collection, a ``__del__``), Python cannot propagate the exception: it prints "Exception ignored
in ..." with a traceback, which the driver forwards to the user's terminal, and the worker keeps
running until Ray kills it. :func:`exit_on_ignored_system_exit` makes such an ignored
``SystemExit`` do what the signal asked: flush the output and end the process with its code,
printing nothing. Every other ignored exception is reported as before.
"""

from __future__ import annotations

import os
import sys
from typing import Any

__all__ = ["exit_on_ignored_system_exit"]


def _hook(unraisable: Any) -> None:
    if isinstance(unraisable.exc_value, SystemExit):
        code = unraisable.exc_value.code
        for stream in (sys.stdout, sys.stderr):
            try:
                stream.flush()
            except Exception:
                pass
        os._exit(code if isinstance(code, int) else 1)
    sys.__unraisablehook__(unraisable)


def exit_on_ignored_system_exit() -> None:
    """Install the hook for this process (idempotent; any thread may call it)."""
    sys.unraisablehook = _hook
