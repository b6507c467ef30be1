"""What a sweep runs: the grid, the seeds and every trial's command-line options, checked
before anything starts (``box2d-driving sweep``, see ``training/sweeps/sweep.py``)."""

from __future__ import annotations

import dataclasses
import importlib
import itertools
import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Optional

PATH_OPTIONS = ("init_from", "spline_init_from")

class SweepError(ValueError):
    """A sweep that cannot start: bad grid, bad trial arguments, or a different sweep in --out."""


@dataclass
class SweepSpec:
    """What a sweep runs (saved as ``sweep.json``; resuming requires the same values).

    Attributes:
        behaviour: the training script (``lights``, ``crosswalk``, ``lanes``, ...).
        grid: script option name -> values, as typed on the command line (every combination runs).
        seeds: training seeds per grid point (0, 1, ..., seeds - 1).
        fixed: script option name -> value, the same for every trial.
        timesteps: slot-decisions per trial (flat trainers; None: the script's default).
        minutes: wall-clock minutes per trial (None: no limit).
        episodes: report episodes per trial evaluation.
        quick: pass ``--quick`` to every trial (a short but real run).
    """

    behaviour: str
    grid: dict[str, list[str]] = field(default_factory=dict)
    seeds: int = 3
    fixed: dict[str, str] = field(default_factory=dict)
    timesteps: Optional[int] = None
    minutes: Optional[float] = None
    episodes: int = 200
    quick: bool = False

    def points(self) -> list[dict[str, str]]:
        keys = list(self.grid)
        return [dict(zip(keys, values)) for values in itertools.product(*(self.grid[k] for k in keys))]

    def trials(self, extra_argv: tuple[str, ...] = ()) -> list[dict[str, Any]]:
        """Every trial's description (what Ray Tune gets as the trial's config); ``extra_argv``
        are options that do not change what is learnt (``--threads``)."""
        return [{"behaviour": self.behaviour, "point": point, "seed": seed,
                 "argv": self.trial_argv(point, seed) + list(extra_argv), "episodes": self.episodes,
                 "name": trial_name(self.behaviour, point, seed), "reuse": None, "extend": None,
                 "carried": None}
                for seed in range(self.seeds) for point in self.points()]  # a whole grid per seed first

    def trial_argv(self, point: dict[str, str], seed: int) -> list[str]:
        """The trial's options; paths that exist here are made absolute (trials run elsewhere)."""
        argv: list[str] = ["--seed", str(seed)]
        for key, value in {**self.fixed, **point}.items():
            argv += _option(self.behaviour, key, value)
        if self.timesteps is not None:
            argv += ["--timesteps", str(self.timesteps)]
        if self.minutes is not None:
            argv += ["--max-minutes", str(self.minutes)]
        if self.quick:
            argv.append("--quick")
        return argv


def spec_differences(saved: dict, spec: "SweepSpec") -> list[str]:
    """The settings in which a saved sweep (``sweep.json``, a summary's ``sweep``) differs from ``spec``."""
    mine = json.loads(json.dumps(dataclasses.asdict(spec)))
    saved, mine = {**saved, "fixed": saved_fixed(saved)}, {**mine, "fixed": saved_fixed(mine)}
    return [k for k in mine if saved.get(k) != mine[k]]


# the budgets an extended sweep (``--extend``) may raise: the flat trainers' decisions and the
# bilevel trainers' rounds
BUDGETS = ("timesteps", "rounds")


def extension_differences(saved: dict, spec: "SweepSpec") -> list[str]:
    """Why ``spec`` cannot continue the trials of the saved sweep ``saved`` (``sweep.json``) to a
    larger budget, one entry per culprit (empty: it can): every setting the same but the number of
    seeds and a larger budget (``timesteps``, or the fixed ``rounds`` of a bilevel sweep)."""
    mine = json.loads(json.dumps(dataclasses.asdict(spec)))
    old_fixed, new_fixed = saved_fixed(saved), saved_fixed(mine)
    out = [k for k in mine if k not in ("seeds", "timesteps", "fixed") and saved.get(k) != mine[k]]
    old_budget = (saved.get("timesteps"), old_fixed.pop("rounds", None))
    new_budget = (mine["timesteps"], new_fixed.pop("rounds", None))
    out += [f"fixed {k}" for k in sorted(set(old_fixed) | set(new_fixed)) if old_fixed.get(k) != new_fixed.get(k)]
    for name, old, new in zip(BUDGETS, old_budget, new_budget):
        try:
            larger = old is not None and new is not None and int(new) > int(old)
        except (TypeError, ValueError):
            larger = False
        if old != new and not larger:
            out.append(f"{name} ({old} -> {new}: an extension trains more, never less or unbounded)")
    if old_budget == new_budget:
        out.append("the budget (neither timesteps nor rounds is larger)")
    return out


def trial_name(behaviour: str, point: dict[str, str], seed: int) -> str:
    parts = [behaviour] + [f"{k}={v}" for k, v in point.items()] + [f"seed={seed}"]
    return "_".join(parts).replace("/", "-")


def script_module(behaviour: str):
    """The training script of ``behaviour`` (the module of its ``train:NAME`` command)."""
    from box2d_driving import plugins

    if behaviour not in plugins.behaviours():
        raise SweepError(f"unknown behaviour {behaviour!r}; choose one of {', '.join(plugins.behaviours())}")
    return importlib.import_module(plugins.command(f"train:{behaviour}").__module__)


def algorithm(behaviour: str) -> Any:
    """The training algorithm of ``behaviour``'s script (:mod:`training.behaviours.algorithms`)."""
    from training.behaviours.algorithms import algorithm_of

    return algorithm_of(script_module(behaviour).Args)


def _option(behaviour: str, key: str, value: str) -> list[str]:
    """``key=value`` as the script's command-line option (``--key value``; booleans as flags)."""
    fields = {f.name: f for f in dataclasses.fields(script_module(behaviour).Args)}
    if key in ("seed", "out", "resume") or key not in fields:
        allowed = sorted(set(fields) - {"seed", "out", "resume"})
        raise SweepError(f"{key!r} is not an option a sweep can set for {behaviour} "
                         f"(seeds come from --seeds, the folder from --out); options: {', '.join(allowed)}")
    flag = "--" + key.replace("_", "-")
    if fields[key].type in ("bool", "Optional[bool]", bool):
        low = str(value).strip().lower()
        if low not in ("true", "false"):
            raise SweepError(f"{key} is true or false, got {value!r}")
        return [flag if low == "true" else "--no-" + key.replace("_", "-")]
    if key in PATH_OPTIONS and Path(value).exists():
        value = str(Path(value).resolve())
    return [flag, str(value)]


def parse_pairs(pairs: list[str], what: str, many: bool) -> dict[str, Any]:
    """``KEY=V1,V2`` (``many``) or ``KEY=V`` pairs as a dict; :class:`SweepError` naming a bad one."""
    out: dict[str, Any] = {}
    for pair in pairs:
        key, sep, value = pair.partition("=")
        key = key.strip().replace("-", "_")
        if not sep or not key or not value.strip():
            raise SweepError(f"{what} expects KEY=VALUE{',VALUE...' if many else ''}, got {pair!r}")
        if key in out:
            raise SweepError(f"{what}: {key} given twice")
        if many:
            values = [v.strip() for v in value.split(",")]
            if any(not v for v in values) or len(set(values)) != len(values):
                raise SweepError(f"{what} {key}: values must be distinct and non-empty, got {value!r}")
            out[key] = values
        else:
            out[key] = value.strip()
    return out


def trial_options(spec: SweepSpec, trial: dict[str, Any]) -> Any:
    """The options one trial of ``spec`` (an item of ``spec.trials()``) trains with: the PPO
    trainers' config (a bilevel run's acceleration stage), or a bandit's. :class:`SweepError` names
    a trial whose options do not parse or make no valid config."""
    from training.common.cli_args import parse
    script = script_module(spec.behaviour)
    argv = trial["argv"] + ["--out", "unused"]
    try:
        args = parse(script.Args, argv)
    except SystemExit:  # argparse has printed which option and value
        raise SweepError(f"trial {trial['name']}: its options do not parse: {' '.join(argv)}") from None
    try:
        config = algorithm(spec.behaviour).config(script.ENV_ID, args)
    except ValueError as exc:
        raise SweepError(f"trial {trial['name']}: {exc}") from None
    return getattr(config, "accel", config)


def check_spec(spec: SweepSpec) -> None:
    """Every trial's arguments parse and make a valid config, before anything is written."""
    trainer = algorithm(spec.behaviour)
    if spec.seeds < 1 or spec.episodes < 1:
        raise SweepError(f"--seeds and --episodes must be >= 1, got {spec.seeds} and {spec.episodes}")
    if spec.timesteps is not None and trainer.budget != "decisions":
        raise SweepError(f"{spec.behaviour} trains in rounds: give --set rounds=N or --minutes, not --timesteps")
    overlap = set(spec.grid) & set(spec.fixed)
    if overlap:
        raise SweepError(f"{', '.join(sorted(overlap))} both in --grid and --set")
    encoders = set()
    worlds: dict[str, set] = {key: set() for key in PINNED_WORLD}
    updates: dict[str, set] = {key: set() for key in PINNED_UPDATE}
    for trial in spec.trials():
        flat = trial_options(spec, trial)
        encoders.add(getattr(flat, "lidar_encoder", None))
        env = getattr(flat, "env_overrides", {}) or {}
        for key, values in worlds.items():
            values.add(env.get(key))
        preset = getattr(flat, "preset", None)
        for key, values in updates.items():  # a preset's update settings (ours are the defaults)
            values.add(getattr(flat, key, None) if preset else None)
    # the encoder its trials build, recorded though not given: a summary says what it ran with,
    # whatever a later default is (saved_fixed reads sweeps from before this)
    if "lidar_encoder" not in spec.grid and "lidar_encoder" not in spec.fixed and len(encoders) == 1 \
            and None not in encoders:
        spec.fixed["lidar_encoder"] = str(encoders.pop())
    for key, values in {**worlds, **updates}.items():  # likewise the settings a preset changed later
        if key not in spec.grid and key not in spec.fixed and len(values) == 1 and None not in values:
            spec.fixed[key] = str(values.pop())


# world settings the paper preset changed on 2026-12-06, after sweeps had run with it, and their
# values before: a sweep records what its trials build (check_spec), and one from before is read
# with these (saved_fixed), so its trials are never taken for runs of the preset's world now
PINNED_WORLD = {"drive_on": "right", "arrived_heading_error": "zero", "goal_distance": "path",
                "light_view": "stop_line", "integration": "exact"}
# likewise the update's settings the paper preset changed later (training options, not the world's)
PINNED_UPDATE = {"value_targets": "lambda_returns"}
# both, as a sweep from before records them
PINNED = {**PINNED_WORLD, **PINNED_UPDATE}


def saved_fixed(saved: dict) -> dict[str, str]:
    """The fixed options of a saved sweep (``sweep.json``, a summary's ``sweep``), with the LiDAR
    encoder of one from before it was recorded: ours (``relu``, the default then), or its
    preset's; and, for a ``paper`` preset sweep from before the preset drove on the left, the
    world it ran in (:data:`PINNED_WORLD`) and the update it trained with (:data:`PINNED_UPDATE`)."""
    from training.ppo.encoder import LEGACY_LIDAR_ENCODER
    from training.trainers.presets import TRAINING_PRESETS

    fixed = dict(saved.get("fixed") or {})
    if "lidar_encoder" not in fixed and "lidar_encoder" not in (saved.get("grid") or {}):
        preset = TRAINING_PRESETS.get(str(fixed.get("preset")))
        fixed["lidar_encoder"] = preset.lidar_encoder if preset is not None else LEGACY_LIDAR_ENCODER
    if fixed.get("preset") == "paper":
        for key, before in PINNED.items():
            if key not in fixed and key not in (saved.get("grid") or {}):
                fixed[key] = before
    return fixed
