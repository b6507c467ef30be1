"""The settings file of an ``--out`` folder of ``box2d-driving original``: what its rollout
tables were drawn with, so that a later run reads them only when it would draw the same ones."""

from __future__ import annotations

import json
from pathlib import Path

from training.original.commands import OriginalError

SETTINGS_FILE = "settings.json"  # what an --out folder's tables were drawn with


def check_settings(out: Path, settings: dict) -> None:
    """Record ``settings`` (episodes, first seed, our world's settings) in ``out``; an ``out``
    whose tables were drawn with other settings is refused (its tables would not compare or pool)."""
    path = out / SETTINGS_FILE
    settings = json.loads(json.dumps(settings))  # as the file holds them (tuples read back as lists)
    if path.exists():
        try:
            before = json.loads(path.read_text())
        except (OSError, ValueError) as exc:
            raise OriginalError(f"--out {out}: {SETTINGS_FILE} is unreadable ({exc})") from None
        if before != settings:
            raise OriginalError(f"--out {out}: its tables were drawn with {before}, not {settings}: choose "
                                "another --out")
        return
    out.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(settings, indent=1) + "\n")
