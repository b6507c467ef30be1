"""Commands that other installed packages plug into ``box2d-driving``, found by entry point.

The world package never imports the trainers. The training package declares its commands in the
entry-point group :data:`COMMANDS` (``setup.cfg``): ``train:lights``, ``train:crosswalk``, ...,
``evaluate``, ``sweep``, ``reproduce``, ``convert-checkpoint`` and ``bench-train``, each naming a
``main(argv) -> int``. The CLI looks one up by name when the user asks for it.
"""

from __future__ import annotations

from importlib.metadata import entry_points
from typing import Callable, Optional

COMMANDS = "box2d_driving.commands"


def command(name: str) -> Optional[Callable[[list[str]], int]]:
    """The ``main(argv)`` of the plugged-in command ``name``, or None where no installed package
    offers it. Raises ``ImportError`` when the command's package is there but its dependencies
    (the train extra) are not."""
    found = [ep for ep in entry_points(group=COMMANDS) if ep.name == name]
    return found[0].load() if found else None


def behaviours() -> list[str]:
    """The behaviours ``train`` offers (entry points ``train:NAME``), sorted by name."""
    return sorted(ep.name.split(":", 1)[1] for ep in entry_points(group=COMMANDS) if ep.name.startswith("train:"))
