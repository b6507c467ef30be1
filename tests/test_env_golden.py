"""Every env steps exactly as it did when ``tests/data/env_golden.json`` was written (see
``tests/env_golden.py``): observations, rewards, dones and infos, bit for bit. Bits can only be
compared on a platform like the recording one (numpy's version and CPU dispatch); elsewhere the
comparison is skipped, saying so."""

import pytest

from tests.env_golden import CASES, fingerprint, platform_signature, recorded

GOLDEN = recorded()


@pytest.mark.parametrize("name,env_id,overrides", CASES, ids=[c[0] for c in CASES])
def test_env_steps_bit_for_bit_as_recorded(name, env_id, overrides):
    here = platform_signature()
    if here not in GOLDEN:
        pytest.skip(f"recorded on {', '.join(GOLDEN)}; this is {here}: add it with "
                    "python -m tests.env_golden --add-platform on code known to be right")
    now = fingerprint(env_id, overrides)
    changed = [part for part in now if now[part] != GOLDEN[here][name][part]]
    assert not changed, f"{name}: {changed} differ from tests/data/env_golden.json ({here})"


def test_every_recorded_platform_has_every_case():
    assert GOLDEN, "tests/data/env_golden.json records no platform"
    for signature, cases in GOLDEN.items():
        assert sorted(cases) == sorted(name for name, _, _ in CASES), signature


def test_fingerprint_sees_a_changed_trajectory():
    a = fingerprint("intersection-v0", {"num_cars": 2}, decisions=30)
    b = fingerprint("intersection-v0", {"num_cars": 2, "lidar_noise": 0.01}, decisions=30)
    assert a["observations"] != b["observations"]
    assert a == fingerprint("intersection-v0", {"num_cars": 2}, decisions=30)
