"""Finding the shipped trained policies by name, from a checkout or a wheel alike.

A source checkout (or an editable install) reads ``assets/policies/``; a wheel carries their
inference files (``config.json``, ``model.safetensors``, ``eval/metrics.json``, ``README.md``;
see ``setup.py``) as ``box2d_driving/policies/shipped/``, so the same name loads the same weights
however the package was installed. A name may be a nested folder
(``real_junction_comm_8cars/noise05``).
"""

from __future__ import annotations

from pathlib import Path
from typing import Union

from box2d_driving.policies.checkpoint_file import FILE

_CHECKOUT_DIR = Path(__file__).resolve().parents[2] / "assets" / "policies"
_PACKAGED_DIR = Path(__file__).resolve().parent / "shipped"
SHIPPED_POLICIES_DIR = _CHECKOUT_DIR if _CHECKOUT_DIR.is_dir() else _PACKAGED_DIR

# what a wheel carries of each policy folder: enough to load it, know its stop value and read its card
# (setup.py copies these; it cannot import the package, so it keeps its own copy of the list)
INFERENCE_FILES = ("config.json", FILE, "eval/metrics.json", "README.md",
                   "accel/config.json", f"accel/{FILE}", f"spline/{FILE}")

__all__ = ["INFERENCE_FILES", "SHIPPED_POLICIES_DIR", "is_policy_folder", "resolve_policy_path", "shipped_policies",
           "shipped_policy"]


def is_policy_folder(path: Path) -> bool:
    """A folder :func:`~box2d_driving.policies.load_trained` can load: ``config.json`` with
    ``model.safetensors`` beside it, or a bilevel run's ``accel/`` and ``spline/``."""
    return (path / "config.json").is_file() and ((path / FILE).is_file() or (path / "accel" / FILE).is_file())


def shipped_policies() -> tuple[str, ...]:
    """Names of the shipped policies (folder paths under the shipped folder), sorted."""
    root = SHIPPED_POLICIES_DIR
    if not root.is_dir():
        return ()
    found = {p.parent for p in root.rglob("config.json") if is_policy_folder(p.parent)}
    found = {p for p in found if not any(q != p and q in p.parents for q in found)}  # not a bilevel's accel/
    return tuple(sorted(p.relative_to(root).as_posix() for p in found))


def shipped_policy(name: str) -> Path:
    """The folder of the shipped policy ``name``; ``KeyError`` (with the names there are) if
    there is none by that name."""
    if name in shipped_policies():
        return SHIPPED_POLICIES_DIR / name
    raise KeyError(f"no shipped policy {name!r} (shipped: {', '.join(shipped_policies()) or 'none'})")


def resolve_policy_path(path: Union[str, Path]) -> Path:
    """Where the policy ``path`` names is, for both loaders (numpy and torch): ``path`` itself, or
    the shipped policy of that name where no such path exists; a folder of several policies in
    sub-folders is refused naming them (:class:`CheckpointError`)."""
    from box2d_driving.policies.checkpoint_file import CheckpointError

    path = shown = Path(path)  # shown: how the error names it (a shipped name stays a name)
    if not path.exists() and len(path.parts) <= 2:
        try:
            path = shipped_policy(path.as_posix())
        except KeyError:
            group = SHIPPED_POLICIES_DIR / path
            if not path.is_absolute() and group.is_dir():  # a shipped folder of several policies
                path = group
    if path.is_dir() and not is_policy_folder(path):
        inside = sorted(p.name for p in path.iterdir() if p.is_dir() and is_policy_folder(p))
        if inside:
            raise CheckpointError(f"{shown} holds no policy of its own but {len(inside)} in sub-folders "
                                  f"({', '.join(inside)}): load one of them, e.g. {(shown / inside[0]).as_posix()}")
    return path
