"""Fingerprints of 1,000 random decisions of every env: observations, rewards, terminations,
truncations and infos, hashed bit for bit (floats through their exact ``repr``).

The env's hot path is optimised from time to time (arrays instead of per-car loops); this keeps
every such change exact. ``tests/test_env_golden.py`` compares with ``tests/data/env_golden.json``,
which holds one set of fingerprints per platform (:func:`platform_signature`: the same code hashes
differently where numpy's CPU dispatch differs). After a change that is *meant* to alter
trajectories, rewrite it (this platform's fingerprints only; the others are dropped, being stale)::

    python -m tests.env_golden --write

To add the platform of the machine at hand, run on code known to be right (a commit whose env code
matched the recorded fingerprints on a recorded platform), keeping the others::

    python -m tests.env_golden --add-platform

A signature may hold more than one set of fingerprints: two machines with the same numpy CPU
dispatch can still round some values differently (seen on 2026-12-02: an AMD EPYC with the
dispatch of an earlier recording gave that recording's observations and rewards but other
``real-junction`` infos, which matched a third machine's). ``--add-platform`` then adds this
machine's set beside the others under its signature; a run matches if it equals one of them.

Each set says where it came from (``recorded``: the commit whose env code it hashed, the CPU model,
the date), so that a stale set can be told from a machine variant by the file alone.
"""

from __future__ import annotations

import datetime
import hashlib
import json
import platform
import subprocess
import sys
from pathlib import Path

import numpy as np

import box2d_driving
from box2d_driving.bench import cpu_model

FILE = Path(__file__).resolve().parent / "data" / "env_golden.json"
DECISIONS = 1_000

# (name, env id, overrides): every registered env, and the options that take other code paths
CASES = (
    ("intersection-4", "intersection-v0", {"num_cars": 4, "lidar_noise": 0.5}),
    ("intersection-8-noiseless", "intersection-v0", {"num_cars": 8}),
    ("highway", "highway-v0", {}),
    ("crosswalk", "crosswalk-v0", {}),
    ("intersection-spline", "intersection-spline-v0", {"num_cars": 4, "lidar_noise": 0.0}),  # as recorded
    ("highway-spline", "highway-spline-v0", {}),
    ("real-junction", "real-junction-v0", {}),
    ("real-junction-messages", "real-junction-v0", {"communication": True, "lidar_noise": 0.25}),
)
PARTS = ("observations", "rewards", "terminations", "truncations", "infos")


def platform_signature() -> str:
    """numpy's version, the machine and the CPU features numpy dispatches on: sin, arctan2 and
    friends round differently in their SIMD and scalar versions, so the fingerprints hold only
    where these match the recording machine's."""
    try:
        from numpy._core._multiarray_umath import __cpu_features__ as features
    except ImportError:  # numpy < 2
        from numpy.core._multiarray_umath import __cpu_features__ as features
    active = ",".join(sorted(k for k, on in features.items() if on))
    return f"numpy {np.__version__}, {platform.machine()}, cpu {hashlib.sha1(active.encode()).hexdigest()[:12]}"


def _canonical(value):
    if isinstance(value, np.ndarray):
        return [_canonical(v) for v in value.tolist()]
    if isinstance(value, dict):
        return {str(k): _canonical(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_canonical(v) for v in value]
    if isinstance(value, (bool, np.bool_)):
        return bool(value)
    if isinstance(value, (int, np.integer)):
        return int(value)
    if isinstance(value, (float, np.floating)):
        return repr(float(value))  # exact: repr round-trips every float64
    return value


def fingerprint(env_id: str, overrides: dict, decisions: int = DECISIONS, seed: int = 7) -> dict[str, str]:
    """sha256 of each part of ``decisions`` random decisions (resets included)."""
    env = box2d_driving.make(env_id, **overrides)
    hashes = {part: hashlib.sha256() for part in PARTS}
    rng = np.random.default_rng(seed)
    n_actions = env.action_space(env.possible_agents[0]).n
    obs, infos = env.reset(seed=seed)
    for _ in range(decisions):
        if not env.agents:
            obs, infos = env.reset()
        actions = {a: int(rng.integers(n_actions)) for a in env.agents}
        obs, rewards, terms, truncs, infos = env.step(actions)
        for agent in sorted(obs):
            hashes["observations"].update(agent.encode() + np.asarray(obs[agent]).tobytes())
            hashes["rewards"].update(np.float64(rewards[agent]).tobytes())
            hashes["terminations"].update(bytes([bool(terms[agent])]))
            hashes["truncations"].update(bytes([bool(truncs[agent])]))
            hashes["infos"].update(json.dumps(_canonical(infos[agent]), sort_keys=True).encode())
    env.close()
    return {part: h.hexdigest() for part, h in hashes.items()}


def recorded() -> dict[str, list[dict[str, dict[str, str]]]]:
    """platform signature -> the fingerprint sets recorded under it (each: case name ->
    fingerprint), as written in :data:`FILE` (their provenance left out: :func:`recorded_sets`)."""
    return {sig: [entry["cases"] for entry in entries] for sig, entries in recorded_sets().items()}


def recorded_sets() -> dict[str, list[dict]]:
    """platform signature -> its entries as written, each ``{"recorded": provenance, "cases":
    case name -> fingerprint}``."""
    return json.loads(FILE.read_text())["platforms"] if FILE.exists() else {}


def provenance() -> dict[str, str]:
    """Where a set recorded now comes from: the commit checked out (``+changes`` when the
    working tree differs from it in the package), the CPU model (for the record only: the
    signature stays numpy's dispatch), today's date (UTC)."""
    root = Path(__file__).resolve().parent.parent
    try:
        commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=root, capture_output=True,
                                text=True, check=True).stdout.strip()
        dirty = subprocess.run(["git", "status", "--porcelain", "--", "box2d_driving"], cwd=root,
                               capture_output=True, text=True, check=True).stdout.strip()
        commit += "+changes" if dirty else ""
    except (OSError, subprocess.CalledProcessError):
        commit = "unknown (no git checkout)"
    today = datetime.datetime.now(datetime.timezone.utc).date().isoformat()
    return {"env_code": commit, "cpu": cpu_model(), "date": today}


def main(argv: list[str]) -> int:
    if argv not in (["--write"], ["--add-platform"]):
        print(__doc__)
        return 2
    platforms = recorded_sets() if argv == ["--add-platform"] else {}
    now = {name: fingerprint(env_id, overrides) for name, env_id, overrides in CASES}
    entries = platforms.setdefault(platform_signature(), [])
    if all(entry["cases"] != now for entry in entries):
        entries.append({"recorded": provenance(), "cases": now})
    FILE.parent.mkdir(exist_ok=True)
    FILE.write_text(json.dumps({"platforms": platforms}, indent=1) + "\n")
    print(f"wrote {FILE}: {len(platforms)} platform(s), {sum(map(len, platforms.values()))} fingerprint set(s)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
