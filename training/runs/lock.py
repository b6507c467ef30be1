"""One trainer per run folder: an exclusive lock held while a run trains or resumes.

The lock is an OS advisory lock (``flock`` on POSIX, ``msvcrt.locking`` on Windows) on
``RUN/.lock``, which also records the holder's process id and host for the error message. The
operating system releases it when the holder exits, however it exits (SIGKILL and power loss
included), so a lock left by a dead process is never stale: the next trainer takes it over.
Advisory locks on network filesystems are only as reliable as the filesystem's locking.
"""

from __future__ import annotations

import contextlib
import json
import os
import socket
from pathlib import Path
from typing import Iterator

from training.runs.run_dir import LOCK_FILE, STORAGE_ERRNOS, RunError, storage_error

try:
    import fcntl
except ImportError:  # pragma: no cover - Windows
    fcntl = None  # type: ignore[assignment]
    import msvcrt

__all__ = ["LOCK_FILE", "RunLockedError", "locked_run", "run_lock"]


class RunLockedError(RunError):
    """Another live process trains in this run folder."""


def _try_lock(fd: int) -> bool:
    try:
        if fcntl is not None:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        else:  # pragma: no cover - Windows
            msvcrt.locking(fd, msvcrt.LK_NBLCK, 1)
    except OSError:
        return False
    return True


def _holder(path: Path) -> str:
    try:
        who = json.loads(path.read_text()[:1000])
        return f"pid {int(who['pid'])} on {str(who['host'])[:100]}"
    except (OSError, ValueError, KeyError, TypeError):
        return "another process"


@contextlib.contextmanager
def run_lock(out: Path) -> Iterator[Path]:
    """Hold ``out``'s lock for the block (creating ``out`` if absent; a folder this call created
    and left holding nothing is removed again, so a run refused by a later check writes nothing).
    :class:`RunLockedError` names the holder when another live process has it."""
    out = Path(out)
    if out.exists() and not out.is_dir():
        raise RunError(f"{out} exists and is not a folder; choose another --out")
    created = not out.exists()
    try:
        out.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise RunError(f"cannot create the run folder {out}: {exc.strerror or exc}") from None
    path = out / LOCK_FILE
    while True:
        try:
            fd = os.open(path, os.O_RDWR | os.O_CREAT, 0o644)
        except OSError as exc:
            raise RunError(f"cannot lock the run folder {out}: {exc.strerror or exc}") from None
        if not _try_lock(fd):
            os.close(fd)
            raise RunLockedError(f"{out} is in use by {_holder(path)} (a training run or --resume "
                                 f"of this folder); wait for it to end, stop it, or choose another --out")
        # the holder before us may have removed the file between our open and our lock: then the
        # lock we hold is on a file nobody else will open; take the one at the path instead
        try:
            same = os.stat(path).st_ino == os.fstat(fd).st_ino
        except FileNotFoundError:
            same = False
        if same:
            break
        os.close(fd)
    try:
        with contextlib.suppress(OSError):  # who holds it, for the message (a full disk may refuse it)
            os.ftruncate(fd, 0)
            os.write(fd, json.dumps({"pid": os.getpid(), "host": socket.gethostname()}).encode())
        yield out
    finally:
        with contextlib.suppress(OSError):
            path.unlink()  # before the release, so that no one locks a file about to go
        os.close(fd)
        if created:
            with contextlib.suppress(OSError):
                out.rmdir()  # only if empty: a run that wrote something keeps its folder


@contextlib.contextmanager
def locked_run(out: Path) -> Iterator[Path]:
    """What a trainer runs in: ``out``'s lock held (:func:`run_lock`), and a write the disk refuses
    (full, read-only, over quota) turned into one :class:`RunError` naming the file."""
    with run_lock(out):
        try:
            yield out
        except OSError as exc:
            if exc.errno not in STORAGE_ERRNOS:
                raise
            raise storage_error(out, exc) from None
