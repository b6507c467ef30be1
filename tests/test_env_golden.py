"""Every env steps exactly as it did when ``tests/data/env_golden.json`` was written (see
``tests/env_golden.py``): observations, rewards, dones and infos, bit for bit. Bits can only be
compared on a platform like the recording one (numpy's version and CPU dispatch); elsewhere the
comparison is skipped, saying so. A platform may hold several recorded sets (machines with the same
dispatch that still round differently); a run must equal one of them in every part."""

import pytest

from tests.env_golden import CASES, fingerprint, platform_signature, provenance, recorded, recorded_sets

GOLDEN = recorded()


@pytest.mark.parametrize("name,env_id,overrides", CASES, ids=[c[0] for c in CASES])
def test_env_steps_bit_for_bit_as_recorded(name, env_id, overrides):
    here = platform_signature()
    if here not in GOLDEN:
        pytest.skip(f"recorded on {', '.join(GOLDEN)}; this is {here}: add it with "
                    "python -m tests.env_golden --add-platform on code known to be right")
    now = fingerprint(env_id, overrides)
    sets = [cases[name] for cases in GOLDEN[here]]
    if now in sets:
        return
    changed = [part for part in now if all(now[part] != fp[part] for fp in sets)]
    why = f"{changed} match none" if changed else "each part matches some set, no set matches all"
    pytest.fail(f"{name}: differs from every fingerprint set recorded for {here} in "
                f"tests/data/env_golden.json ({why})")


def test_every_recorded_platform_has_every_case():
    assert GOLDEN, "tests/data/env_golden.json records no platform"
    for signature, sets in GOLDEN.items():
        assert sets, signature
        for cases in sets:
            assert sorted(cases) == sorted(name for name, _, _ in CASES), signature


def test_every_recorded_set_says_where_it_came_from():
    for signature, entries in recorded_sets().items():
        for entry in entries:
            assert sorted(entry) == ["cases", "recorded"], signature
            assert sorted(entry["recorded"]) == ["cpu", "date", "env_code"], signature
            assert all(entry["recorded"].values()), signature
    now = provenance()
    assert now["env_code"] and now["cpu"] and len(now["date"]) == 10


def test_fingerprint_sees_a_changed_trajectory():
    a = fingerprint("intersection-v0", {"num_cars": 2}, decisions=30)
    b = fingerprint("intersection-v0", {"num_cars": 2, "lidar_noise": 0.01}, decisions=30)
    assert a["observations"] != b["observations"]
    assert a == fingerprint("intersection-v0", {"num_cars": 2}, decisions=30)
