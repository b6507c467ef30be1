"""Checkpoints never run code from the file: a crafted pickled policy is refused on every path that
loads one, and a user's own older checkpoint converts only with an explicit opt-in."""

from __future__ import annotations

import base64
import json
import pickle
import shutil
import zipfile
from pathlib import Path

import numpy as np
import pytest

th = pytest.importorskip("torch")
pytest.importorskip("stable_baselines3")

from tests.helpers import tiny_train_config  # noqa: E402
from training.runs.checkpoint import CheckpointError, read_checkpoint  # noqa: E402
from training.runs.inference import load_policy  # noqa: E402
from training.trainers.trainer import RunError, TrainConfig, build_model, load_ppo, make_vec_env, train  # noqa: E402
from tests.helpers import HANG  # noqa: E402


class _Payload:
    """Unpickling this creates ``marker``: what a malicious file could do with any code."""

    def __init__(self, marker: Path) -> None:
        self.marker = str(marker)

    def __reduce__(self):
        return (open, (self.marker, "w"))


def _tiny(**kw) -> TrainConfig:
    return tiny_train_config(**{"timesteps": 160, "checkpoint_every": 1, **kw})


@pytest.fixture(scope="module")
def run(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("ckpt") / "run"
    train(_tiny(), out)
    return out


def _legacy_zip(config: TrainConfig, path: Path, payload: object = None) -> None:
    """A genuine SB3 ``model.zip``; with ``payload``, one more pickled attribute in its data."""
    model = build_model(config, make_vec_env(config))
    model.save(path)
    if payload is None:
        return
    with zipfile.ZipFile(path) as zf:
        parts = {name: zf.read(name) for name in zf.namelist()}
    data = json.loads(parts["data"])
    data["innocent_looking"] = {":type:": "<class 'object'>",
                               ":serialized:": base64.b64encode(pickle.dumps(payload)).decode()}
    parts["data"] = json.dumps(data).encode()
    with zipfile.ZipFile(path, "w") as zf:
        for name, blob in parts.items():
            zf.writestr(name, blob)


@pytest.fixture
def crafted(run, tmp_path):
    """A run folder whose model.zip runs code when unpickled, and the marker that code creates."""
    folder = tmp_path / "downloaded"
    folder.mkdir()
    shutil.copy(run / "config.json", folder / "config.json")
    shutil.copy(run / "state.json", folder / "state.json")
    marker = tmp_path / "PWNED"
    _legacy_zip(_tiny(), folder / "model.zip", _Payload(marker))
    return folder, marker


def test_a_crafted_pickle_is_refused_everywhere_and_never_runs(crafted, tmp_path):
    from box2d_driving.cli import main as cli
    from training.evaluation import evaluate

    folder, marker = crafted
    with pytest.raises(CheckpointError, match="pickled"):
        load_policy(folder)
    with pytest.raises(CheckpointError, match="pickled"):
        load_policy(folder / "model.zip")
    disguised = tmp_path / "disguised"
    disguised.mkdir()
    shutil.copy(folder / "config.json", disguised / "config.json")
    shutil.copy(folder / "model.zip", disguised / "model.safetensors")  # renamed, still a zip
    with pytest.raises(CheckpointError, match="pickled"):
        load_policy(disguised)
    (disguised / "model.safetensors").write_bytes(pickle.dumps(_Payload(marker)))  # a bare pickle
    with pytest.raises(CheckpointError, match="no safetensors header"):
        load_policy(disguised)
    assert evaluate.main(["--checkpoint", str(folder), "--episodes", "1",
                          "--out", str(tmp_path / "ev")]) == 2
    assert cli(["render", "intersection-v0", "--policy", str(folder), "--out", str(tmp_path / "v.mp4")]) == 2
    with pytest.raises(RunError, match="pickled"):
        train(_tiny(init_from=str(folder)), tmp_path / "fine_tune")
    with pytest.raises(RunError, match="pickled"):
        train(_tiny(timesteps=320), folder, resume=True)
    from training.runs import convert_checkpoint
    assert convert_checkpoint.main([str(folder)]) == 2  # no --trust-pickle: nothing is unpickled
    assert not marker.exists()
    # the payload is live: SB3's own loader runs it (so the checks above could have failed)
    from stable_baselines3 import PPO
    try:
        PPO.load(folder / "model.zip", device="cpu")
    except Exception:
        pass
    assert marker.exists()


def test_own_old_checkpoint_converts_with_trust_pickle(run, tmp_path):
    from stable_baselines3 import PPO

    from training.runs import convert_checkpoint

    old = tmp_path / "old"
    old.mkdir()
    shutil.copy(run / "config.json", old / "config.json")
    _legacy_zip(_tiny(), old / "model.zip")
    (old / "checkpoints").mkdir()
    shutil.copy(old / "model.zip", old / "checkpoints" / "model_80.zip")
    assert convert_checkpoint.main([str(old), "--trust-pickle"]) == 0
    assert (old / "model.safetensors").exists() and (old / "checkpoints" / "model_80.safetensors").exists()
    assert convert_checkpoint.main([str(old), "--trust-pickle"]) == 2  # would overwrite
    policy = load_policy(old)
    reference = PPO.load(old / "model.zip", device="cpu").policy
    env = policy.make_env()
    obs, _ = env.reset(seed=3)
    x = th.as_tensor(np.stack(list(obs.values())))
    with th.no_grad():
        expected = reference.action_net(reference.mlp_extractor.forward_actor(x)).argmax(1).tolist()
    assert list(policy.act(obs).values()) == expected
    assert read_checkpoint(old).optimizer is not None  # a converted run can be resumed
    with pytest.raises(RunError, match="state.json"):
        train(_tiny(timesteps=240), old, resume=True)
    # the state.json saved with that checkpoint (its decisions match) makes it resumable
    at = read_checkpoint(old).counters["num_timesteps"]
    (old / "state.json").write_text(json.dumps({"decisions": at + 80, "agent_steps": 0, "wall_s": 1.0}))
    with pytest.raises(RunError, match="state.json is missing or is not model.safetensors's"):
        train(_tiny(timesteps=240), old, resume=True)  # another checkpoint's state is not taken
    (old / "state.json").write_text(json.dumps({"decisions": at, "agent_steps": 0, "wall_s": 1.0}))
    train(_tiny(timesteps=240), old, resume=True)


def test_load_ppo_gives_a_plain_sb3_model(run, tmp_path):
    from stable_baselines3 import PPO

    model = load_ppo(run)
    assert isinstance(model, PPO) and model.num_timesteps == 160
    policy = load_policy(run)
    env = policy.make_env()
    obs, _ = env.reset(seed=1)
    own = np.stack(list(obs.values()))
    slot = np.zeros((len(own), model.observation_space.shape[0]), np.float32)
    slot[:, :own.shape[1]] = own
    actions, _ = model.predict(slot, deterministic=True)
    assert actions.tolist() == list(policy.act(obs).values())


def test_malformed_checkpoints_are_one_clear_error(run, tmp_path):
    from safetensors.torch import save_file

    bad = tmp_path / "bad"
    bad.mkdir()
    shutil.copy(run / "config.json", bad / "config.json")
    blob = (run / "model.safetensors").read_bytes()
    (bad / "model.safetensors").write_bytes(blob[: len(blob) // 2])  # truncated
    with pytest.raises(CheckpointError, match="unreadable|header"):
        load_policy(bad)
    save_file({"x": th.zeros(2)}, str(bad / "model.safetensors"))  # not ours
    with pytest.raises(CheckpointError, match="not a box2d-driving-checkpoint"):
        load_policy(bad)
    ckpt = read_checkpoint(run)
    weights = {f"policy/{k}": v for k, v in ckpt.policy.items()}
    weights["policy/action_net.bias"] = th.zeros(3)
    save_file(weights, str(bad / "model.safetensors"),
              metadata={"format": "box2d-driving-checkpoint", "version": "1", "counters": "{}"})
    with pytest.raises(CheckpointError, match="action_net.bias"):
        load_policy(bad)
    (bad / "config.json").write_text("[1, 2]")
    with pytest.raises(CheckpointError, match="JSON object"):
        load_policy(bad)


def test_weights_read_are_a_copy_not_a_view_of_the_file(run, tmp_path):
    """A checkpoint rewritten in place after it was read (a sweep's trial folder while Ray Tune
    syncs it) leaves the weights read intact. Memory-mapped weights would end the process with
    SIGBUS here, so the check runs in a child process and looks at how it ended."""
    import subprocess
    import sys

    shutil.copytree(run, tmp_path / "run")
    code = (
        "import sys; from pathlib import Path\n"
        "from training.runs.checkpoint import read_checkpoint\n"
        "from box2d_driving.policies.checkpoint_file import read_arrays\n"
        "run = Path(sys.argv[1]); model = run / 'model.safetensors'\n"
        "ckpt = read_checkpoint(run); _, arrays, _ = read_arrays(run)\n"
        "before = {k: v.clone() for k, v in ckpt.policy.items()}\n"
        "arrays_before = {k: v.copy() for k, v in arrays.items()}\n"
        "model.write_bytes(b'')  # truncated in place: the same file, now empty\n"
        "assert all((ckpt.policy[k] == v).all() for k, v in before.items())\n"
        "assert all((arrays[k] == v).all() for k, v in arrays_before.items())\n"
        "print('intact')\n")
    done = subprocess.run([sys.executable, "-c", code, str(tmp_path / "run")], capture_output=True, text=True,
                          cwd=Path(__file__).resolve().parents[1], timeout=HANG)
    assert done.returncode == 0 and "intact" in done.stdout, (done.returncode, done.stderr[-2000:])


def test_a_run_folders_algorithm_is_read_from_its_config(tmp_path):
    from box2d_driving.policies.checkpoint_file import CheckpointError, is_bilevel_run, run_algorithm

    run = tmp_path / "run"
    (run / "accel").mkdir(parents=True)
    (run / "spline").mkdir()
    assert run_algorithm(run) is None and not is_bilevel_run(run)  # no config.json: not a run folder
    (run / "config.json").write_text("{}")  # written before runs recorded it: the folders say
    assert run_algorithm(run) == "bilevel-ppo" and is_bilevel_run(run)
    (run / "config.json").write_text(json.dumps({"algorithm": "ppo"}))  # recorded: the record decides
    assert run_algorithm(run) == "ppo" and not is_bilevel_run(run)
    (run / "config.json").write_text(json.dumps({"algorithm": "sac"}))
    with pytest.raises(CheckpointError, match="algorithm 'sac' is none this package reads"):
        run_algorithm(run)
    assert run_algorithm(run / "config.json") is None  # a file is no run folder


def test_the_loaders_read_every_algorithm_the_trainers_record():
    from box2d_driving.policies.checkpoint_file import ALGORITHMS as READ
    from training.behaviours.algorithms import ALGORITHMS as TRAINED

    assert sorted(a.name for a in TRAINED) == sorted(READ)
