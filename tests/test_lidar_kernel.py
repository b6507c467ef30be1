"""The compiled LiDAR kernel's shortcuts against testing every ray on every segment.

The kernel tests a segment only against the rays inside the angle it subtends (found with an
approximate ``atan2``) and keeps each car's ray directions while its heading stays the same. Both
are shortcuts that must not change a single distance: here the kernel is compared bit for bit
with a plain loop over every ray and every segment through the kernel's own hit test (``_ray_hit``).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from box2d_driving.sensors import lidar


def every_ray_on_every_segment(origins, headings, observer, n_rays, max_range, segs, owner, one_sided):
    """Closest hits with no culling at all: each ray against each segment, the kernel's own hit test."""
    dtheta = 2.0 * math.pi / n_rays
    out = np.full((len(origins), n_rays), np.inf)
    for c in range(len(origins)):
        ox, oy, h = float(origins[c, 0]), float(origins[c, 1]), float(headings[c])
        for k in range(n_rays):
            rc, rs = math.cos(h + k * dtheta), math.sin(h + k * dtheta)
            for m in range(len(segs)):
                if owner[m] == observer[c]:
                    continue
                ax, ay = segs[m, 0] - ox, segs[m, 1] - oy
                ex, ey = segs[m, 2] - ox - ax, segs[m, 3] - oy - ay
                out[c, k] = lidar._ray_hit(ax, ay, ex, ey, rc, rs, one_sided[m], max_range, out[c, k], 0.0)
    return out


def scene(rng, n_cars, n_edges, spread):
    """Cars at random poses, long and short edges, and edges passing through or grazing a car's
    centre (where the subtended angle is close to 180 degrees)."""
    pos = rng.uniform(-spread, spread, (n_cars, 2))
    head = rng.uniform(-math.pi, math.pi, n_cars)
    edges = [rng.uniform(-2 * spread, 2 * spread, (n_edges, 4))]
    short = rng.uniform(-spread, spread, (n_edges, 2))
    angle = rng.uniform(-math.pi, math.pi, n_edges)
    edges.append(np.concatenate([short, short + np.stack([np.cos(angle), np.sin(angle)], axis=1)], axis=1))
    for gap in (0.0, 1e-9, 1e-6, 1e-3, 0.05):  # lines past car 0 at these distances, both ways
        d = rng.normal(size=2)
        d /= np.linalg.norm(d)
        normal = np.array([-d[1], d[0]]) * gap
        edges.append(np.concatenate([pos[0] + normal - 30 * d, pos[0] + normal + 30 * d])[None])
        edges.append(np.concatenate([pos[0] - normal + 2 * d, pos[0] - normal + 60 * d])[None])
    return pos, head, np.concatenate(edges)


@pytest.mark.parametrize("seed", range(6))
def test_culled_kernel_equals_testing_every_ray_on_every_segment(seed):
    rng = np.random.default_rng(seed)
    n_cars, n_rays = 6, [36, 100, 7][seed % 3]
    pos, head, edges = scene(rng, n_cars, 12, [5.0, 25.0][seed % 2])
    segs, owner, one_sided = lidar.scene_segments(pos, head, np.ones(n_cars, dtype=bool), 4.0, 2.0,
                                                  rng.uniform(-10, 10, (2, 2)), np.array([0.8, 0.6]), edges)
    observers = np.arange(n_cars)
    got = np.empty((n_cars, n_rays))
    lidar.cast_rays(pos, head, observers, n_rays, 40.0, segs, owner, one_sided, got)
    want = every_ray_on_every_segment(pos, head, observers, n_rays, 40.0, segs, owner, one_sided)
    assert got.tobytes() == want.tobytes()
    assert np.isfinite(got).sum() > n_cars * n_rays // 4


def test_kept_ray_directions_change_no_distance():
    """A memo filled by other cars, other headings and other scenes gives what a fresh one gives,
    and a slot whose heading is unchanged keeps its directions."""
    rng = np.random.default_rng(7)
    n, rays = 5, 60
    memo = lidar.RayDirections(2 * n, rays)
    for _ in range(20):
        pos = rng.uniform(-20, 20, (2 * n, 2))
        head = rng.uniform(-math.pi, math.pi, 2 * n)
        head[:3] = [0.25, 0.25, -1.0]  # some slots keep their heading from call to call
        present = rng.random(2 * n) < 0.9
        edges = rng.uniform(-30, 30, (8, 4))
        observers = np.flatnonzero(present)
        args = (pos, head, present, n, observers, 4.0, 2.0, np.zeros((0, 2)), np.zeros(0),
                np.zeros(2, dtype=np.int64), edges, np.array([5, 3]), rays, 40.0)
        kept = lidar.cast_rays_scenes(*args, memo)
        fresh = lidar.cast_rays_scenes(*args)
        assert kept.tobytes() == fresh.tobytes()
        np.testing.assert_array_equal(memo.heading[observers], head[observers])
        rng.shuffle(memo.heading)  # slots now hold directions of other headings than their own
    assert lidar.RayDirections.sized(memo, 2 * n, rays) is memo
    assert lidar.RayDirections.sized(memo, 2 * n, rays + 1) is not memo
    with pytest.raises(ValueError, match="slots x rays"):
        lidar.cast_rays_scenes(*args[:-2], rays + 1, 40.0, memo)


def test_approximate_atan2_is_within_its_bound():
    rng = np.random.default_rng(3)
    points = np.concatenate([rng.normal(size=(20_000, 2)) * 10.0 ** rng.uniform(-6, 3, (20_000, 1)),
                             [[1.0, 0.0], [-1.0, 0.0], [0.0, 1.0], [0.0, -1.0], [1.0, 1.0], [-1.0, 1.0],
                              [1.0, -1e-300], [-1.0, -1e-300], [0.0, 0.0]]])
    for y, x in points[:, ::-1]:
        err = lidar._approx_atan2(y, x) - math.atan2(y, x)
        err = (err + math.pi) % (2 * math.pi) - math.pi  # -pi and pi are the same direction
        assert abs(err) <= 2e-5, (y, x)
    # both ends of a span may be off by the bound; the margin stays far below a ray spacing
    assert 2 * 2e-5 < lidar._SPAN_MARGIN < 2 * math.pi / 360 / 10
