"""Commands that other installed packages plug into ``box2d-driving``, found by entry point.

The world package never imports the trainers. The training package declares its commands in the
entry-point group :data:`COMMANDS` (``setup.cfg``): ``train:lights``, ``train:crosswalk``, ...,
``evaluate``, ``sweep``, ``reproduce``, ``curve``, ``check-shipped``, ``convert-checkpoint`` and
``bench-train``, each naming a ``main(argv) -> int``. The CLI looks one up by name when the user asks for it.
"""

from __future__ import annotations

from importlib.metadata import entry_points
from pathlib import Path
from typing import Any, Callable, Optional

COMMANDS = "box2d_driving.commands"
API = "box2d_driving.api"  # functions: train, load_policy (torch)


def command(name: str) -> Optional[Callable[[list[str]], int]]:
    """The ``main(argv)`` of the plugged-in command ``name``, or None where no installed package
    offers it. Raises ``ImportError`` when the command's package is there but its dependencies
    (the train extra) are not."""
    return _load(COMMANDS, name)


def _load(group: str, name: str) -> Optional[Callable[..., Any]]:
    """The object entry point ``name`` of ``group`` names (after :func:`check_training_package`),
    or None where no installed package offers it; an ``ImportError`` of its module propagates."""
    found = [ep for ep in entry_points(group=group) if ep.name == name]
    if not found:
        return None
    check_training_package()
    return found[0].load()


def check_training_package() -> None:
    """Refuse a ``training`` package other than this install's: a user's own ``training/``
    folder earlier on the import path (the current folder, for a script) would otherwise be
    imported in its place and fail somewhere deep inside. Ours sits beside ``box2d_driving``, in
    a checkout and in ``site-packages`` alike."""
    import importlib.util
    import sys

    ours = Path(__file__).resolve().parents[1] / "training"
    loaded = sys.modules.get("training")
    if loaded is not None:
        where = getattr(loaded, "__file__", None)
    else:
        try:
            spec = importlib.util.find_spec("training")
        except (ImportError, ValueError):
            return
        where = None if spec is None else spec.origin
    if where is None:
        return  # not installed (or a namespace without files): the callers say what to install
    found = Path(where).resolve().parent
    if found != ours:
        raise CommandMissing(f"needs box2d-driving's training package ({ours}), but the one Python finds first is "
                             f"{found}: a folder of yours named training shadows it; run from another folder or "
                             "rename yours")


class CommandMissing(LookupError):
    """A command the user asked for is not installed, or its dependencies are not."""


def install_hint(extra: str) -> str:
    """The command that adds ``extra`` to this install: the editable one with the CPU constraints
    in a source checkout (``setup.py`` beside the package), the package index's otherwise (a
    wheel user has neither the checkout nor its constraints file)."""
    if (Path(__file__).resolve().parents[1] / "setup.py").is_file():
        return f'pip install -c constraints-cpu.txt -e ".[{extra}]"'
    return f'pip install "box2d-driving[{extra}]"'


INSTALL = install_hint("train")


def require(name: str) -> Callable[[list[str]], int]:
    """:func:`command` ``name``, or :class:`CommandMissing` saying what to install (and, where
    the package is there, which import failed)."""
    try:
        found = command(name)
    except ImportError as exc:
        raise CommandMissing(f"needs the train extra ({INSTALL}): {exc}") from None
    if found is None:
        raise CommandMissing(f"needs the train extra ({INSTALL})")
    return found


def behaviours() -> list[str]:
    """The behaviours ``train`` offers (entry points ``train:NAME``), sorted by name."""
    return sorted(ep.name.split(":", 1)[1] for ep in entry_points(group=COMMANDS) if ep.name.startswith("train:"))


def api(name: str) -> Callable[..., Any]:
    """The function ``name`` the training package offers in the group :data:`API`, or
    :class:`CommandMissing` saying what to install."""
    try:
        found = _load(API, name)
    except ImportError as exc:
        raise CommandMissing(f"needs the train extra ({INSTALL}): {exc}") from None
    if found is None:
        raise CommandMissing(f"needs the train extra ({INSTALL})")
    return found
