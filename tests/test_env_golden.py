"""Every env steps exactly as it did when ``tests/data/env_golden.json`` was written (see
``tests/env_golden.py``): observations, rewards, dones and infos, bit for bit. Bits can only be
compared on a platform like the recording one (numpy's version and CPU dispatch); elsewhere the
comparison is skipped, saying so."""

import json

import pytest

from tests.env_golden import CASES, FILE, fingerprint, platform_signature

GOLDEN = json.loads(FILE.read_text())


@pytest.mark.parametrize("name,env_id,overrides", CASES, ids=[c[0] for c in CASES])
def test_env_steps_bit_for_bit_as_recorded(name, env_id, overrides):
    if platform_signature() != GOLDEN["platform"]:
        pytest.skip(f"recorded on {GOLDEN['platform']}, this is {platform_signature()}: "
                    "rewrite with python -m tests.env_golden --write on code known to be right")
    now = fingerprint(env_id, overrides)
    changed = [part for part in now if now[part] != GOLDEN[name][part]]
    assert not changed, f"{name}: {changed} differ from tests/data/env_golden.json"


def test_fingerprint_sees_a_changed_trajectory():
    a = fingerprint("intersection-v0", {"num_cars": 2}, decisions=30)
    b = fingerprint("intersection-v0", {"num_cars": 2, "lidar_noise": 0.01}, decisions=30)
    assert a["observations"] != b["observations"]
    assert a == fingerprint("intersection-v0", {"num_cars": 2}, decisions=30)
