"""Convert a run folder's older SB3 ``model.zip`` files to ``model.safetensors``.

    box2d-driving convert-checkpoint runs/lights4 --trust-pickle

Releases before this one saved checkpoints with SB3's ``model.save``: a zip of cloudpickled
Python objects. Reading one runs whatever code its author put in it, so nothing in this project
loads them any more. This command is the one exception, for files you made yourself: it unpickles
``model.zip`` (and ``accel/``, ``spline/`` and ``checkpoints/*.zip`` of the same run) with
``PPO.load`` and writes each as a ``.safetensors`` file beside it (weights, optimiser state,
counters; see ``training/runs/checkpoint.py``). It refuses to run without ``--trust-pickle``: never pass
that flag for a file someone else could have written (a download, a shared drive, an e-mail).
The ``.zip`` files are left in place; delete them once the conversion is checked.
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path
from typing import Optional

from training.runs.checkpoint import FILE, CheckpointError, save_model
from training.common.cli_args import error, parse


@dataclass
class Args:
    """Convert pickled model.zip checkpoints of your own to model.safetensors.

    path: run folder (model.zip, accel/, spline/, checkpoints/) or one .zip file
    trust_pickle: confirm that you wrote these files yourself: loading them runs any code they hold
    overwrite: replace .safetensors files that already exist
    """

    path: str = ""
    trust_pickle: bool = False
    overwrite: bool = False


def legacy_files(path: Path) -> list[Path]:
    """The SB3 zips of a run folder (or the one file given)."""
    if path.is_file():
        return [path]
    found = [p for p in (path / "model.zip", path / "accel" / "model.zip", path / "spline" / "model.zip")
             if p.is_file()]
    for folder in (path, path / "accel", path / "spline"):
        found += sorted((folder / "checkpoints").glob("*.zip"))
    return found


def target(zip_path: Path) -> Path:
    """Where the converted weights of ``zip_path`` go."""
    return zip_path.with_name(FILE) if zip_path.name == "model.zip" else zip_path.with_suffix(".safetensors")


def convert(args: Args) -> list[Path]:
    """Convert the SB3 ``model.zip`` files of a run folder (or one file) into safetensors files
    beside them, only with ``--trust-pickle``; returns the files written."""
    path = Path(args.path)
    if not args.path or not path.exists():
        raise CheckpointError(f"no run folder or file at {args.path!r}")
    if not args.trust_pickle:
        raise CheckpointError("refusing to unpickle without --trust-pickle: a model.zip can run any "
                              "code when loaded; pass the flag only for files you wrote yourself")
    files = legacy_files(path)
    if not files:
        raise CheckpointError(f"no model.zip files in {path}")
    clash = [target(f) for f in files if target(f).exists()]
    if clash and not args.overwrite:
        raise CheckpointError(f"{clash[0]} exists; pass --overwrite to replace it")
    from stable_baselines3 import PPO

    written = []
    for f in files:
        try:
            model = PPO.load(f, device="cpu")  # the unpickling the user vouched for
        except Exception as exc:
            raise CheckpointError(f"{f}: not an SB3 PPO checkpoint ({exc})") from None
        written.append(save_model(model, target(f)))
    return written


def main(argv: Optional[list[str]] = None) -> int:
    argv = list(sys.argv[1:] if argv is None else argv)
    if argv and not argv[0].startswith("-"):  # the path may come first, without --path
        argv = ["--path"] + argv
    args = parse(Args, argv, description=__doc__.split("\n\n")[0])
    try:
        written = convert(args)
    except CheckpointError as exc:
        return error(str(exc))
    for path in written:
        print(f"wrote {path}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
