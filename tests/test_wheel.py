"""The same world from a wheel as from a checkout: a wheel built from this tree carries the
junction maps and the shipped policies, and its single-agent envs drive the same background."""

from __future__ import annotations

import ast
import os
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

from box2d_driving.policies.shipped import INFERENCE_FILES, SHIPPED_POLICIES_DIR, shipped_policies
from tests.helpers import HANG

ROOT = Path(__file__).resolve().parents[1]

_CHECK = """
import json, sys, warnings
warnings.filterwarnings("error", message=".*shipped background")  # a scripted fall-back warns so
import gymnasium as gym
import box2d_driving
from box2d_driving.policies import load_trained
from box2d_driving.policies.shipped import shipped_policies
from box2d_driving.maps.shipped import shipped_maps
env = gym.make("box2d_driving/Intersection-v0").unwrapped
obs, _ = env.reset(seed=3)
policy = load_trained("traffic_lights_4cars_noise05")
print(json.dumps({"file": box2d_driving.__file__, "background": env.background_name,
                  "policies": list(shipped_policies()), "maps": list(shipped_maps()),
                  "stop_value": policy.stop_value, "obs": [float(x) for x in obs[:5]]}))
"""


def _run_check(env: dict, cwd: Path) -> dict:
    import json

    done = subprocess.run([sys.executable, "-c", _CHECK], cwd=cwd, env=env, capture_output=True, text=True,
                          timeout=HANG)
    assert done.returncode == 0, done.stderr[-3000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_setup_copies_the_files_the_package_looks_for():
    tree = ast.parse((ROOT / "setup.py").read_text())
    wanted = [node for node in tree.body if isinstance(node, ast.Assign)
              and any(isinstance(t, ast.Name) and t.id in ("WEIGHTS", "POLICY_FILES") for t in node.targets)]
    values: dict = {}
    exec(compile(ast.Module(body=wanted, type_ignores=[]), "setup.py", "exec"), values)  # two constants
    assert values["POLICY_FILES"] == INFERENCE_FILES


@pytest.mark.skipif(not (ROOT / "assets" / "policies").is_dir(), reason="needs a source checkout")
def test_a_wheel_gives_the_same_world_as_the_checkout(tmp_path):
    built = subprocess.run([sys.executable, "-m", "pip", "wheel", "--no-deps", "--no-build-isolation", "-q",
                            "-w", str(tmp_path / "dist"), str(ROOT)], capture_output=True, text=True, timeout=HANG)
    assert built.returncode == 0, built.stderr[-3000:]
    wheel = next((tmp_path / "dist").glob("box2d_driving-*.whl"))
    size = wheel.stat().st_size
    assert size < 20 * 2**20, f"the wheel is {size / 2**20:.1f} MiB"  # weights for inference only
    unpacked = tmp_path / "site"
    with zipfile.ZipFile(wheel) as zf:
        names = zf.namelist()
        assert not [n for n in names if n.endswith(("progress.csv", ".mp4", ".png", "state.json"))]
        zf.extractall(unpacked)
    # the unpacked wheel first on the path, run from a folder with no assets/ above it
    env = {**os.environ, "PYTHONPATH": str(unpacked), "SDL_VIDEODRIVER": "dummy"}
    from_wheel = _run_check(env, tmp_path)
    from_checkout = _run_check({**os.environ, "SDL_VIDEODRIVER": "dummy"}, ROOT)
    assert from_wheel["file"].startswith(str(unpacked)) and not from_checkout["file"].startswith(str(unpacked))
    assert from_wheel["background"] == from_checkout["background"] == "shipped:traffic_lights_4cars_noise05"
    for key in ("policies", "maps", "stop_value", "obs"):
        assert from_wheel[key] == from_checkout[key], key
    assert set(from_wheel["policies"]) == set(shipped_policies()) and len(from_wheel["policies"]) >= 10


def test_shipped_policies_load_by_name_and_a_folder_of_several_says_which():
    from box2d_driving.policies import CheckpointError, load_trained

    assert "real_junction_comm_8cars/noise05" in shipped_policies()
    assert load_trained("real_junction_comm_8cars/noise05").env_id == "real-junction-v0"
    with pytest.raises(CheckpointError,
                       match=r"holds no policy of its own but 1 in sub-folders \(noise05\): load one of them"):
        load_trained(SHIPPED_POLICIES_DIR / "real_junction_comm_8cars")
    with pytest.raises(CheckpointError, match=r"^real_junction_comm_8cars holds no policy of its own but 1 in "
                       r"sub-folders \(noise05\): load one of them, e.g. real_junction_comm_8cars/noise05$"):
        load_trained("real_junction_comm_8cars")  # by its shipped name: answered with names
    with pytest.raises(CheckpointError, match="no checkpoint at no_such_policy"):
        load_trained("no_such_policy")
