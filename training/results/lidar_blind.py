"""The results page's line on whether a section's kept actors use their LiDAR.

An actor whose LiDAR encoder went dead drives blind to the other cars (docs/paper_world.md, "The
LiDAR encoder"); a reader weighing a claim about LiDAR noise needs to know how many of the trials
behind a row are such actors. Each finished trial with kept weights is measured once by
:func:`training.evaluation.lidar_use.kept_lidar_use` (the result kept beside its weights), and so
is the policy a fine-tune starts from: a dead unit passes no gradient, so a fine-tune of a blind
actor is blind too unless something revives it.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any, Optional

__all__ = ["blind_line", "start_line"]


def blind_line(summary: dict[str, Any], keys: list[str]) -> Optional[str]:
    """``"LiDAR use of the kept actors ...: k of n blind"`` per grid point of ``summary`` (its
    finished trials whose flat weights are kept), or None where none are kept."""
    from training.evaluation.lidar_use import KEPT_EPISODES, kept_lidar_use
    from training.results.data import as_number
    from training.results.matching import grid_value
    from training.sweeps.kept import kept_folder

    path = Path(summary["path"])
    folder = kept_folder(path.parent, path.stem)
    counts: dict[tuple[str, ...], list[int]] = {}
    for trial in summary["trials"]:
        if trial.get("status") != "done":
            continue
        use = kept_lidar_use(folder / trial["trial"])
        if use is None:
            continue
        point = tuple(str(trial.get(k)) for k in keys)
        seen = counts.setdefault(point, [0, 0])
        seen[0] += use.blind
        seen[1] += 1
    if not counts:
        return None
    parts = [(", ".join(f"{k} {v}" for k, v in zip(keys, point)) + ": " if keys else "") + f"{b} of {n} blind"
             for point, (b, n) in sorted(counts.items(), key=lambda item: [grid_value(v) for v in item[0]])]
    fixed_noise = str(summary.get("sweep", {}).get("fixed", {}).get("lidar_noise", ""))
    all_dropped = as_number(fixed_noise) == 1.0 or any(
        k == "lidar_noise" and as_number(v) == 1.0 for point in counts for k, v in zip(keys, point))
    return (f"LiDAR use of the kept actors (`box2d-driving lidar-use`, {KEPT_EPISODES} selection episodes each; "
            "blind: LiDAR features that do not move, an actor that cannot see the other cars, "
            f"[why](paper_world.md#the-lidar-encoder)): {'; '.join(parts)}"
            + (" (at LiDAR noise 1.0 every ray is dropped: every actor is blind there by design)" if all_dropped
               else "") + ".")


def start_line(summary: dict[str, Any], kept: int) -> Optional[str]:
    """Whether the policy the trials of ``summary`` fine-tune (its fixed ``init_from``, where that
    is a flat policy's folder here) uses its LiDAR; for trials from scratch with our encoder and
    no kept weights, that their LiDAR use is unknown; else None. ``kept``: how many of the trials'
    own final weights are kept (measured in :func:`blind_line`'s line)."""
    from training.evaluation.lidar_use import KEPT_EPISODES, kept_lidar_use

    fixed = summary.get("sweep", {}).get("fixed", {})
    start = fixed.get("init_from")
    if not start and fixed.get("lidar_encoder") == "relu" and not kept:
        return ("These trials start from scratch with our LiDAR encoder (`lidar_encoder=relu`), whose last unit "
                "is dead from the start for 6 of 20 training seeds in the 4-car lights world and can die in "
                "training ([why](paper_world.md#the-lidar-encoder)); their final weights were not kept, so how "
                "many of these actors see the other cars is not known.")
    use = kept_lidar_use(Path(start)) if start and Path(start).is_dir() else None
    if use is None:
        return None
    measured = (f"`box2d-driving lidar-use`, {KEPT_EPISODES} selection episodes: LiDAR feature spread "
                f"{use.feature_spread:.1e}, an empty scan changes {100 * use.actions_changed:.1f} % of its actions; "
                "[why](paper_world.md#the-lidar-encoder)")
    if use.blind:
        return (f"These trials start from `{start}`, whose actor is **blind** to its LiDAR ({measured}): its "
                "encoder's last unit is dead or nearly so. A dead unit passes no gradient and stays dead; a nearly "
                "dead one may revive in training. " + (
                    "The trials' own kept actors are measured below." if kept else
                    "Their own final weights were not kept, so whether these actors see the other cars is not known."))
    return f"These trials start from `{start}`, whose actor's LiDAR features vary ({measured})."
