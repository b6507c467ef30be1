"""Does a trained actor use its LiDAR? ``box2d-driving lidar-use POLICY...``

An actor whose LiDAR encoder has gone dead (our ReLU encoder's last unit, on one channel, zero for
every observation: no gradient ever revives it) drives by the light and its own speed alone,
blind to the other cars, and can still score well on red lights. Such a policy cannot speak to a
claim about LiDAR noise, so the results page's reader needs to know. For each policy this drives
its own world with the policy for ``--episodes`` selection episodes and reports, over every
decision seen:

* ``feature_spread``: the largest standard deviation, across those observations, of the 25
  pooled LiDAR features the actor's MLP reads (0: the same features whatever the LiDAR sees);
* ``actions_changed``: the share of decisions whose greedy action changes when the LiDAR columns
  are emptied (0 = no return within range, as a dropped ray reads);
* ``blind``: ``feature_spread`` below 1e-4 (the LiDAR values themselves span 0 to 10).

    box2d-driving lidar-use assets/sweeps/weights/lights-preset/* --episodes 20

The policies are read with numpy (:func:`box2d_driving.policies.load_trained`), as ``evaluate``
reads kept trial weights; seeds from :data:`training.common.seeds.SELECTION`.
"""

from __future__ import annotations

import argparse
import json
import sys
from dataclasses import asdict, dataclass
from pathlib import Path
from typing import Optional

import numpy as np

from training.common.seeds import SELECTION
from training.ppo.encoder import BLIND_SPREAD
from training.runs.run_dir import write_json_atomic

__all__ = ["BLIND_SPREAD", "KEPT_FILE", "LidarUse", "kept_lidar_use", "lidar_use", "main"]

# a kept trial's measurement, beside its weights (``assets/sweeps/weights/NAME/<trial>/``), on this
# many selection episodes: seeded, so measuring again gives the same numbers
KEPT_FILE, KEPT_EPISODES = "lidar_use.json", 20


@dataclass(frozen=True)
class LidarUse:
    """What :func:`lidar_use` measured of one policy (see the module docstring)."""

    policy: str
    encoder: str
    decisions: int
    feature_spread: float
    actions_changed: float

    @property
    def blind(self) -> bool:
        return self.feature_spread < BLIND_SPREAD


def lidar_use(path: str, episodes: int = 20, first_seed: int = SELECTION.start) -> LidarUse:
    """Measure one policy (a run folder, a kept trial's weights or a shipped policy's name) on
    ``episodes`` episodes of its own world from seed ``first_seed``, driven by the policy."""
    from box2d_driving.policies import load_trained

    policy = load_trained(path)
    actor = getattr(policy, "actor", None)
    if actor is None or not hasattr(actor, "lidar_features"):
        raise ValueError(f"{path}: not a LiDAR-driving actor (a spline stage or scripted policy?)")
    env = policy.make_env()
    rows = []
    for episode in range(episodes):
        obs, _ = env.reset(seed=first_seed + episode)
        while env.agents:
            rows.append(np.stack([obs[a] for a in env.agents]))
            obs, *_ = env.step(policy.act({a: obs[a] for a in env.agents}))
    env.close()
    seen = np.concatenate(rows).astype(np.float32)
    n_lidar = actor.history * actor.n_rays
    empty = seen.copy()
    empty[:, :n_lidar] = 0.0
    spread = float(actor.lidar_features(seen).std(axis=0).max())
    changed = float(np.mean(actor.logits(seen).argmax(1) != actor.logits(empty).argmax(1)))
    return LidarUse(str(path), "original" if actor.original else "relu", len(seen), spread, changed)


def kept_lidar_use(folder: Path) -> Optional[LidarUse]:
    """The LiDAR use of the actor kept in ``folder`` (a sweep trial's kept weights), read from its
    ``lidar_use.json`` or measured on :data:`KEPT_EPISODES` selection episodes and written there;
    None for a folder without a flat run's weights (a bilevel run's stages)."""
    folder = Path(folder)
    if not (folder / "model.safetensors").is_file():
        return None
    cached = folder / KEPT_FILE
    if cached.is_file():
        try:
            saved = json.loads(cached.read_text())
            return LidarUse(str(folder), str(saved["encoder"]), int(saved["decisions"]),
                            float(saved["feature_spread"]), float(saved["actions_changed"]))
        except (ValueError, KeyError, TypeError):
            pass  # unreadable: measured again below and replaced
    use = lidar_use(str(folder), KEPT_EPISODES)
    write_json_atomic(cached, {"episodes": KEPT_EPISODES, "first_seed": SELECTION.start, "encoder": use.encoder,
                               "decisions": use.decisions, "feature_spread": use.feature_spread,
                               "actions_changed": use.actions_changed, "blind": use.blind})
    return use


def main(argv: Optional[list[str]] = None) -> int:
    p = argparse.ArgumentParser(prog="box2d-driving lidar-use",
                                description="Whether trained actors use their LiDAR: the spread of their "
                                            "LiDAR features and the share of decisions an empty scan "
                                            "changes, on selection episodes of their own world.")
    p.add_argument("policies", nargs="+", metavar="POLICY",
                   help="run folders, kept trial weights or shipped policy names")
    p.add_argument("--episodes", type=int, default=20, help="selection episodes per policy (default 20)")
    p.add_argument("--json", metavar="FILE", help="also write the rows to this JSON file")
    args = p.parse_args(argv)
    if args.episodes < 1:
        p.error(f"--episodes must be >= 1, got {args.episodes}")
    rows = []
    print(f"{'policy':<60} {'encoder':<8} {'decisions':>9} {'feature spread':>14} {'actions changed':>15}  blind")
    for path in args.policies:
        try:
            use = lidar_use(path, args.episodes)
        except ValueError as exc:  # CheckpointError too: the file, named
            p.error(str(exc))
        rows.append({**asdict(use), "blind": use.blind})
        print(f"{use.policy[-60:]:<60} {use.encoder:<8} {use.decisions:>9} {use.feature_spread:>14.2e} "
              f"{use.actions_changed:>15.3f}  {'yes' if use.blind else 'no'}", flush=True)
    blind = sum(r["blind"] for r in rows)
    print(f"{blind} of {len(rows)} blind to their LiDAR", file=sys.stderr)
    if args.json:
        Path(args.json).write_text(json.dumps(rows, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
