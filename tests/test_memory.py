"""No memory growth over resets (training runs reset their envs millions of times)."""

from __future__ import annotations

import sys

import pytest

import box2d_driving
from box2d_driving.memcheck import reset_growth

# Measured with `box2d-driving bench --memory`: 0.00-0.02 MiB per 1,000 resets for every env.
# Before the fix: real-junction-v0 about 50, the others 2-4. The bound is generous (allocator
# noise over a few hundred resets) yet well below either.
BOUND_MIB_PER_1000 = 1.5


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads the resident set size from /proc")
@pytest.mark.parametrize("env_id", list(box2d_driving.registry()))
def test_resets_do_not_grow_memory(env_id):
    result = reset_growth(env_id, resets=400, steps=2, warmup=100)
    assert result.mib_per_1000_resets < BOUND_MIB_PER_1000, result
