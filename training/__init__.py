"""Training: PPO with a centralised critic over a slot VecEnv, the behaviours' scripts,
evaluation, sweeps and the results page. Needs the ``train`` extra
(``pip install -c constraints-cpu.txt -e ".[train]"``).

Sub-packages, each importing only those listed before it:

* :mod:`training.common`: seed ranges, the dataclass-as-CLI helper;
* :mod:`training.ppo`: the SB3 extensions (network, rollout buffer, vector env, bandit);
* :mod:`training.runs`: checkpoints, loading a policy into torch, run folders, progress logs;
* :mod:`training.trainers`: the PPO and bilevel training loops, the training benchmark;
* :mod:`training.behaviours`: one script per behaviour (``box2d-driving train NAME``);
* :mod:`training.evaluation`: ``box2d-driving evaluate`` and its reports;
* :mod:`training.sweeps`: ``box2d-driving sweep`` on Ray Tune;
* :mod:`training.original`: the paper's own simulator and trainer beside ours (``box2d-driving original``);
* :mod:`training.results`: ``box2d-driving reproduce``, the results page.

Module paths of earlier releases (``training.trainer``, ``training.inference``, ``training.sweep``
...) still import: each is the module it became (see :data:`MOVED`), so code and Ray Tune
experiment folders that name them keep working.
"""

from __future__ import annotations

import importlib
import importlib.abc
import importlib.util
import sys

# earlier flat module -> where it lives now
MOVED = {
    "seeds": "common.seeds", "cli_args": "common.cli_args",
    "encoder": "ppo.encoder", "policy": "ppo.policy", "buffer": "ppo.buffer", "vec_env": "ppo.vec_env",
    "bandit": "ppo.bandit", "shared_policy": "ppo.shared_policy",
    "checkpoint": "runs.checkpoint", "inference": "runs.inference", "weights": "runs.weights",
    "run_dir": "runs.run_dir", "progress": "runs.progress", "convert_checkpoint": "runs.convert_checkpoint",
    "trainer": "trainers.trainer", "bilevel": "trainers.bilevel", "bench_train": "trainers.bench_train",
    "scripts": "behaviours.scripts", "traffic_lights": "behaviours.traffic_lights",
    "crosswalk": "behaviours.crosswalk", "lanes": "behaviours.lanes", "fast_lanes": "behaviours.fast_lanes",
    "real_junction": "behaviours.real_junction", "single_agent_ppo": "behaviours.single_agent_ppo",
    "evaluate": "evaluation.evaluate", "reports": "evaluation.reports", "plots": "evaluation.plots",
    "checkpoint_curve": "evaluation.checkpoint_curve", "communication_table": "evaluation.communication_table",
    "figure_data": "evaluation.figure_data",
    "sweep": "sweeps.sweep", "sweep_spec": "sweeps.spec", "sweep_summary": "sweeps.summary",
    "reproduce": "results.reproduce", "reproduce_run": "results.run_all", "results_data": "results.data",
    "results_sections": "results.sections", "results_statements": "results.statements",
    "results_figures": "results.figures",
}


class MovedModules(importlib.abc.MetaPathFinder, importlib.abc.Loader):
    """Imports ``training.OLD`` as the module :data:`MOVED` says it became (the same object, so
    ``isinstance`` checks and pickles by name agree across both paths)."""

    def find_spec(self, name, path=None, target=None):
        head, _, old = name.partition(".")
        if head == __name__ and old in MOVED:  # its file as origin: runpy makes it sys.argv[0]
            origin = importlib.util.find_spec(f"{__name__}.{MOVED[old]}").origin
            return importlib.util.spec_from_loader(name, self, origin=origin)
        return None

    def create_module(self, spec):
        return importlib.import_module(f"{__name__}.{MOVED[spec.name.partition('.')[2]]}")

    def exec_module(self, module) -> None:  # the new module ran when it was imported
        pass

    # ``python -m training.OLD`` (runpy) runs the new module's code as ``__main__``
    def get_code(self, fullname):
        new = f"{__name__}.{MOVED[fullname.partition('.')[2]]}"
        return importlib.util.find_spec(new).loader.get_code(new)

    def is_package(self, fullname) -> bool:
        return False


if not any(isinstance(f, MovedModules) for f in sys.meta_path):
    sys.meta_path.append(MovedModules())

__all__ = ["MOVED", "TorchPolicy", "TrainedPolicy", "load_policy"]


def __getattr__(name: str):
    """``training.load_policy`` and ``training.TorchPolicy`` (``TrainedPolicy``, its earlier name), imported
    on first use: importing
    a light sub-module (``training.common.seeds``) does not load torch."""
    if name in ("TorchPolicy", "TrainedPolicy", "load_policy"):
        from training.runs import inference

        return getattr(inference, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
