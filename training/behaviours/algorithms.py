"""The training algorithms by name: what a behaviour's script, a sweep trial and its checks run.

Each :class:`Algorithm` says which arguments its scripts take (a dataclass of
:mod:`training.behaviours.scripts`), how those arguments become the trainer's config, how it
trains a run folder (resumable, reporting every checkpoint) and how its last statistics and
checkpoints are named. A behaviour's script picks its algorithm by its arguments' class
(:func:`algorithm_of`); ``box2d-driving train NAME``, ``sweep`` and its trial checks all go through
:func:`run_script` and the record, so a third algorithm is one more entry in :data:`ALGORITHMS`.

* ``ppo``: SB3 PPO with the centralised critic (``training.trainers.trainer``);
* ``bilevel-ppo``: the paper's Algorithm 1, the spline stage as a one-step bandit alternating with
  acceleration PPO (``training.trainers.bilevel``), budgets in rounds.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Callable, Optional

from training.behaviours.scripts import BilevelArgs, CommonArgs, ScriptArgs, bilevel_config_from, config_from
from training.common.cli_args import parse, prog_name
from training.trainers.trainer import RunError

__all__ = ["ALGORITHMS", "Algorithm", "algorithm_of", "run_script"]


@dataclass(frozen=True)
class Algorithm:
    """A training algorithm as scripts and sweeps use it.

    Attributes:
        name: its name.
        args: the arguments dataclass its scripts' ``Args`` derive from.
        config: ``(env id, parsed args) -> the trainer's config``.
        train: ``(config, out, resume=, on_checkpoint=) -> last statistics``; resumable, locked.
        budget: what a run's length is counted in (``decisions`` or ``rounds``).
        last: what the summary line calls the last statistics.
        weights: where a finished run folder keeps its weights, in words.
    """

    name: str
    args: type
    config: Callable[[str, Any], Any]
    train: Callable[..., dict[str, Any]]
    budget: str
    last: str
    weights: Callable[[Path], str]


def _train_ppo(config: Any, out: Path, resume: bool = False,
               on_checkpoint: Optional[Callable[[dict], None]] = None) -> dict[str, Any]:
    from training.trainers.trainer import train

    return train(config, out, resume=resume, on_checkpoint=on_checkpoint)


def _train_bilevel(config: Any, out: Path, resume: bool = False,
                   on_checkpoint: Optional[Callable[[dict], None]] = None) -> dict[str, Any]:
    from training.trainers.bilevel import train_bilevel

    return train_bilevel(config, out, resume=resume, on_checkpoint=on_checkpoint)


ALGORITHMS = (
    Algorithm("bilevel-ppo", BilevelArgs, bilevel_config_from, _train_bilevel, "rounds", "last round",
              lambda out: f"checkpoints: {out / 'accel'} and {out / 'spline'}"),
    Algorithm("ppo", ScriptArgs, config_from, _train_ppo, "decisions", "last update",
              lambda out: f"checkpoint: {out / 'model.safetensors'}"),
)


def algorithm_of(args_class: type) -> Algorithm:
    """The algorithm whose scripts take ``args_class`` (a subclass of its arguments dataclass);
    ``TypeError`` naming the class where none does."""
    for algorithm in ALGORITHMS:
        if issubclass(args_class, algorithm.args):
            return algorithm
    raise TypeError(f"{args_class.__name__} derives from no algorithm's arguments "
                    f"({', '.join(a.args.__name__ for a in ALGORITHMS)})")


def run_script(env_id: str, args_class: type[CommonArgs], argv: Optional[list[str]], doc: str) -> int:
    """A behaviour's ``box2d-driving train NAME``: parse ``argv`` into ``args_class``, train with
    its algorithm, print a summary; the exit status (2: bad input, 128 + N: stopped by signal N
    with the run saved)."""
    name = prog_name()
    algorithm = algorithm_of(args_class)
    args = parse(args_class, argv, description=(doc or "").split("\n\n")[0])
    out = Path(args.out)
    try:
        stats = algorithm.train(algorithm.config(env_id, args), out, resume=args.resume)
    except (RunError, ValueError) as exc:
        print(f"{name}: error: {exc}", file=sys.stderr)
        return 2
    signum = stats.pop("interrupted_by_signal", None)
    print(f"{algorithm.last}:", {k.split("/")[-1]: round(v, 4) if isinstance(v, float) else v
                                 for k, v in stats.items()})
    print(algorithm.weights(out))
    if signum is not None:
        print(f"{name}: interrupted by signal {signum}: run saved; continue with --resume --out {args.out}",
              file=sys.stderr)
        return 128 + signum
    return 0
