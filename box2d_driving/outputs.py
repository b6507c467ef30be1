"""Writing outputs so that nothing half-written survives and ``--overwrite`` replaces whole.

* :func:`fresh_dir`: build a folder's contents in a hidden sibling, then swap it in; the old
  contents go (no stale files from an earlier run), and an error, Ctrl-C or SIGTERM leaves the
  old folder as it was and no partial one.
* :func:`terminate_as_interrupt`: SIGTERM raises ``KeyboardInterrupt`` like Ctrl-C, so that the
  cleanup of a ``try``/``finally`` runs when a job scheduler stops the process too.
* :class:`GracefulStop`: SIGINT / SIGTERM only set a flag, for loops (training) that want to finish
  the step they are in, save, and exit; a second signal interrupts at once.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import threading
import uuid
from pathlib import Path
from typing import Iterator, Optional

_SIGNALS = (signal.SIGINT, signal.SIGTERM)


def _main_thread() -> bool:
    return threading.current_thread() is threading.main_thread()


@contextlib.contextmanager
def terminate_as_interrupt() -> Iterator[None]:
    """Within the block, SIGTERM raises ``KeyboardInterrupt`` (main thread only)."""
    if not _main_thread():
        yield
        return

    def handler(signum, frame):
        raise KeyboardInterrupt(f"stopped by signal {signum}")

    previous = signal.signal(signal.SIGTERM, handler)
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


@contextlib.contextmanager
def fresh_dir(final: Path, overwrite: bool = False) -> Iterator[Path]:
    """Yield an empty temporary folder beside ``final`` to write into. When the block ends
    normally it becomes ``final`` (replacing an existing one whole, if ``overwrite``); on any
    exception or interruption it is deleted and ``final`` is left untouched."""
    final = Path(final)
    if final.exists() and not final.is_dir():
        raise FileExistsError(f"{final} exists and is not a folder")
    if final.exists() and any(final.iterdir()) and not overwrite:
        raise FileExistsError(f"{final} exists and is not empty; choose another --out or pass --overwrite")
    final.parent.mkdir(parents=True, exist_ok=True)
    tmp = final.with_name(f".{final.name}.partial-{uuid.uuid4().hex[:8]}")
    tmp.mkdir()
    try:
        with terminate_as_interrupt():
            yield tmp
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    old = None
    if final.exists():
        old = final.with_name(f".{final.name}.old-{uuid.uuid4().hex[:8]}")
        os.replace(final, old)
    os.replace(tmp, final)
    if old is not None:
        shutil.rmtree(old, ignore_errors=True)


class GracefulStop:
    """``with stop.installed(): ...`` makes SIGINT and SIGTERM set ``stop.signum`` instead of
    killing the process; a loop checks ``stop.requested`` at a safe point. A second signal
    restores the default behaviour and raises at once (for a stuck process)."""

    def __init__(self) -> None:
        self.signum: Optional[int] = None

    @property
    def requested(self) -> bool:
        return self.signum is not None

    @contextlib.contextmanager
    def installed(self) -> Iterator["GracefulStop"]:
        if not _main_thread():
            yield self
            return
        previous = {s: signal.getsignal(s) for s in _SIGNALS}

        def handler(signum, frame):
            if self.signum is not None:  # the second one: stop now
                raise KeyboardInterrupt(f"stopped by signal {signum}")
            self.signum = signum

        for s in _SIGNALS:
            signal.signal(s, handler)
        try:
            yield self
        finally:
            for s, h in previous.items():
                signal.signal(s, h)
