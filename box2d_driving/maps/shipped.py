"""Finding maps by name: the junctions shipped under ``assets/maps/`` or any map JSON file."""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path

from box2d_driving.maps.parse import load_map
from box2d_driving.maps.roadmap import MapError, RoadMap

# A repository checkout (or editable install) reads assets/maps/; a wheel carries a copy of them
# in the package (setup.py).
_CHECKOUT_DIR = Path(__file__).resolve().parent.parent.parent / "assets" / "maps"
_PACKAGED_DIR = Path(__file__).resolve().parent / "junctions"
SHIPPED_DIR = _CHECKOUT_DIR if _CHECKOUT_DIR.is_dir() else _PACKAGED_DIR


def shipped_maps() -> tuple[str, ...]:
    """Names of the shipped maps (file stems under ``assets/maps/``), sorted."""
    return tuple(sorted(p.stem for p in SHIPPED_DIR.glob("*.json")))


def resolve_map(name_or_path: str) -> Path:
    """The file of a shipped map name or a path to a map JSON (:class:`MapError` if neither)."""
    try:  # a name no file system accepts (too long, a NUL byte) is simply not found
        candidate = SHIPPED_DIR / f"{name_or_path}.json"
        if candidate.is_file():
            return candidate
        path = Path(name_or_path)
        if path.is_file():
            return path.resolve()
    except (OSError, ValueError):
        pass
    raise MapError(f"unknown map {name_or_path!r}: not a shipped map ({', '.join(shipped_maps()) or 'none found'}) "
                   f"nor an existing file")


def get_map(name_or_path: str) -> RoadMap:
    """The map, loaded once per file version (maps are read-only to their users)."""
    path = resolve_map(name_or_path)
    return _load(str(path), path.stat().st_mtime_ns)


@lru_cache(maxsize=64)
def _load(path: str, _mtime: int) -> RoadMap:
    return load_map(path)
