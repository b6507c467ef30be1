"""The code's layout keeps its promises: imports point one way (no circles anywhere, the world
package never imports the trainer, the trainer's sub-packages only import those below them), and
the module paths of earlier releases still import."""

from __future__ import annotations

import ast
import importlib
from pathlib import Path

import pytest
from tests.helpers import HANG

ROOT = Path(__file__).resolve().parent.parent
# the trainer's sub-packages, lowest first: each may import only itself and those before it
LAYERS = ("common", "ppo", "runs", "trainers", "behaviours", "evaluation", "sweeps", "original", "results")


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


MODULES = {_module_name(p): p for pkg in ("box2d_driving", "training") for p in (ROOT / pkg).rglob("*.py")}


def _project_module(name: str):
    """The project module ``name`` is, or is inside (``a.b.func`` -> ``a.b``); None if not ours."""
    while name and name not in MODULES:
        name = name.rpartition(".")[0]
    return name or None


def imports_of(module: str) -> set[str]:
    """The project modules ``module`` imports anywhere in its file (also inside functions, and
    string arguments of ``importlib.import_module``), leaving out its own sub-packages (``from
    box2d_driving.envs import base`` names a sibling, not the package's ``__init__``) but not its
    root package: ``import box2d_driving`` runs the root's ``__init__``, which imports most of
    the package, so a module the root's ``__init__`` reaches must not import it back."""
    found = set()
    for node in ast.walk(ast.parse(MODULES[module].read_text(encoding="utf-8"))):
        if isinstance(node, ast.Import):
            found.update(_project_module(a.name) for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.add(_project_module(node.module))
            found.update(_project_module(f"{node.module}.{a.name}") for a in node.names)
        elif isinstance(node, ast.Call) and getattr(node.func, "attr", getattr(node.func, "id", "")) == "import_module":
            found.update(_project_module(a.value) for a in node.args
                         if isinstance(a, ast.Constant) and isinstance(a.value, str))
    return {m for m in found if m and m != module and ("." not in m or not module.startswith(m + "."))}


GRAPH = {m: imports_of(m) for m in MODULES}


def test_the_world_package_never_imports_the_trainer():
    offenders = {m: sorted(d for d in deps if d.split(".")[0] == "training")
                 for m, deps in GRAPH.items() if m.split(".")[0] == "box2d_driving"}
    assert not {m: d for m, d in offenders.items() if d}


def test_no_module_imports_itself_round_a_circle():
    seen: dict[str, int] = {}  # 1: on the current path, 2: finished

    def visit(m: str, path: list[str]) -> None:
        seen[m] = 1
        for d in sorted(GRAPH[m]):
            if seen.get(d) == 1:
                pytest.fail("import circle: " + " -> ".join(path[path.index(d):] + [d]))
            if d not in seen:
                visit(d, path + [d])
        seen[m] = 2

    for m in sorted(GRAPH):
        if m not in seen:
            visit(m, [m])


def _layer(module: str):
    parts = module.split(".")
    return LAYERS.index(parts[1]) if len(parts) > 1 and parts[0] == "training" and parts[1] in LAYERS else None


def test_the_trainers_sub_packages_import_only_those_below_them():
    assert {p.name for p in (ROOT / "training").iterdir() if (p / "__init__.py").exists()} == set(LAYERS)
    upward = [f"{m} -> {d}" for m, deps in GRAPH.items() if _layer(m) is not None
              for d in deps if d.split(".")[0] == "training" and (_layer(d) is None or _layer(d) > _layer(m))]
    assert not upward, upward


def test_every_sub_package_says_what_lives_there():
    for name in LAYERS:
        doc = ast.get_docstring(ast.parse((ROOT / "training" / name / "__init__.py").read_text()))
        assert doc and "Imports" in doc, name


def test_the_module_paths_of_earlier_releases_still_import():
    pytest.importorskip("torch")
    import training
    from training import load_policy
    from training.runs.inference import load_policy as now
    from training.trainer import load_ppo
    from training.trainers.trainer import load_ppo as load_ppo_now

    assert load_policy is now and load_ppo is load_ppo_now
    for old, new in training.MOVED.items():
        assert importlib.import_module(f"training.{old}") is importlib.import_module(f"training.{new}")


def test_an_old_module_path_runs_with_python_m_and_light_modules_do_not_load_torch():
    import subprocess
    import sys

    ran = subprocess.run([sys.executable, "-m", "training.lanes", "--help"], cwd=ROOT, capture_output=True,
                         text=True, timeout=HANG)
    assert ran.returncode == 0 and "usage: lanes.py" in ran.stdout, ran.stderr[-2000:]
    light = subprocess.run([sys.executable, "-c", "import sys, training.common.seeds; print('torch' in sys.modules)"],
                           cwd=ROOT, capture_output=True, text=True, timeout=HANG)
    assert light.stdout.strip() == "False", light.stderr[-2000:]


def test_the_world_imports_box2d_through_one_module_and_warns_about_nothing():
    """box2d-py's SWIG bindings warn at import on Python 3.11+ (three DeprecationWarnings with
    tracebacks in every docs build and test run); the world imports Box2D only through
    ``box2d_driving.physics.box2d_py``, which keeps those three quiet and nothing else."""
    import subprocess
    import sys

    importers = [p.relative_to(ROOT).as_posix() for p in (ROOT / "box2d_driving").rglob("*.py")
                 if any(isinstance(node, (ast.Import, ast.ImportFrom))
                        and "Box2D" in ([a.name for a in node.names] if isinstance(node, ast.Import) else [node.module])
                        for node in ast.walk(ast.parse(p.read_text(encoding="utf-8"))))]
    assert importers == ["box2d_driving/physics/box2d_py.py"]
    script = ("import box2d_driving\n"
              "env = box2d_driving.make('intersection-v0', num_cars=2)\n"
              "env.reset(seed=0)\n"
              "env.step({a: 0 for a in env.agents})\n")
    ran = subprocess.run([sys.executable, "-W", "error::DeprecationWarning", "-c", script], cwd=ROOT,
                         capture_output=True, text=True, timeout=HANG)
    assert ran.returncode == 0, ran.stderr[-2000:]
