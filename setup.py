"""Setup (metadata in setup.cfg). The junction maps under ``assets/maps/`` are copied into the
package as ``box2d_driving/maps/junctions/`` so that a wheel install finds them too."""

import shutil
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

MAPS = Path(__file__).resolve().parent / "assets" / "maps"


class BuildPyWithMaps(build_py):
    def run(self) -> None:
        super().run()
        dst = Path(self.build_lib) / "box2d_driving" / "maps" / "junctions"
        dst.mkdir(parents=True, exist_ok=True)
        for path in sorted(MAPS.glob("*.json")) + [MAPS / "README.md"]:  # maps + attribution
            shutil.copy2(path, dst / path.name)


setup(cmdclass={"build_py": BuildPyWithMaps})
