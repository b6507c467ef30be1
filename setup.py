"""Setup (metadata in setup.cfg). Two asset folders are copied into the package so that a wheel
install finds what a checkout reads under ``assets/``:

* the junction maps (``assets/maps/*.json``) as ``box2d_driving/maps/junctions/``;
* the shipped policies' inference files (``assets/policies/NAME/``: config, weights, evaluation
  metrics, card; the bilevel runs' ``accel/`` and ``spline/`` weights) as
  ``box2d_driving/policies/shipped/NAME/``, so the single-agent envs drive the same background
  cars and ``load_trained(NAME)`` loads the same weights from a wheel as from a checkout.

This file imports nothing from the package (a wheel is built without its dependencies).
"""

import shutil
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

ASSETS = Path(__file__).resolve().parent / "assets"
MAPS = ASSETS / "maps"
POLICIES = ASSETS / "policies"
WEIGHTS = "model.safetensors"
# the inference files of a policy folder (box2d_driving/policies/shipped.py lists the same)
POLICY_FILES = ("config.json", WEIGHTS, "eval/metrics.json", "README.md",
                "accel/config.json", f"accel/{WEIGHTS}", f"spline/{WEIGHTS}")


def policy_folders(root: Path) -> list:
    """Folders under ``root`` that hold a loadable policy (config and weights, or a bilevel run)."""
    found = [p.parent for p in sorted(root.rglob("config.json"))
             if (p.parent / WEIGHTS).is_file() or (p.parent / "accel" / WEIGHTS).is_file()]
    return [p for p in found if not any(q != p and q in p.parents for q in found)]  # not a bilevel's accel/


class BuildPyWithAssets(build_py):
    def run(self) -> None:
        super().run()
        package = Path(self.build_lib) / "box2d_driving"
        maps = package / "maps" / "junctions"
        maps.mkdir(parents=True, exist_ok=True)
        for path in sorted(MAPS.glob("*.json")) + [MAPS / "README.md"]:  # maps + attribution
            shutil.copy2(path, maps / path.name)
        for folder in policy_folders(POLICIES):
            dst = package / "policies" / "shipped" / folder.relative_to(POLICIES)
            for name in POLICY_FILES:
                if (folder / name).is_file():
                    (dst / name).parent.mkdir(parents=True, exist_ok=True)
                    shutil.copy2(folder / name, dst / name)


setup(cmdclass={"build_py": BuildPyWithAssets})
