"""A one-line note the first time this install compiles its numba kernels.

The physics, LiDAR and observation kernels are compiled for the machine on their first call and
cached (``cache=True``: ``__pycache__`` beside each module, or ``NUMBA_CACHE_DIR``). That first
call takes 5-40 s depending on the machine and its load, during which nothing else is printed; a
user at a terminal is told why. Nothing is printed where stderr is not a terminal (logs, tests,
pipes) or once the cache holds the LiDAR caster's compiled code.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

_said = False


def kernels_cached() -> bool:
    """Whether numba's cache holds the LiDAR caster (the first kernel an env's reset runs)."""
    from box2d_driving.sensors import lidar

    # numba caches in NUMBA_CACHE_DIR where it is set, else beside the module
    place = Path(os.environ.get("NUMBA_CACHE_DIR") or Path(lidar.__file__).parent / "__pycache__")
    return place.is_dir() and next(place.rglob("lidar.*.nbi"), None) is not None


def note_first_compile() -> None:
    """Print the note once per process, if it applies (see the module docstring)."""
    global _said
    if _said:
        return
    _said = True
    try:
        interactive = sys.stderr.isatty()
    except (AttributeError, ValueError):
        interactive = False
    if interactive and not kernels_cached():
        print("box2d-driving: compiling the simulator's kernels for this machine (once; 5-40 s, cached "
              "afterwards)", file=sys.stderr, flush=True)
