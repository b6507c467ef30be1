"""Paths and centripetal Catmull-Rom splines."""

import numpy as np
import pytest

from box2d_driving.road.geometry import Path, catmull_rom, catmull_rom_many, spline_path, spline_paths, wrap_angle


CONTROL = np.array([[0.0, 0.0], [10.0, 4.0], [25.0, -3.0], [40.0, 8.0]])


def test_spline_passes_through_its_control_points():
    pts = catmull_rom(CONTROL, samples_per_segment=50)
    for c in CONTROL:
        assert np.min(np.linalg.norm(pts - c, axis=1)) < 1e-12
    assert np.array_equal(pts[0], CONTROL[0]) and np.array_equal(pts[-1], CONTROL[-1])


def _true_length(control):
    fine = catmull_rom(control, samples_per_segment=20000)
    return np.sum(np.linalg.norm(np.diff(fine, axis=0), axis=1))


def test_arc_length_parameterisation_is_accurate_to_a_centimetre():
    path = spline_path(CONTROL)
    assert path.length == pytest.approx(_true_length(CONTROL), abs=0.01)
    # walking the path by arc length gives points whose spacing matches the arc length
    s = np.linspace(0, path.length, 401)
    p, _ = path.pose(s)
    steps = np.linalg.norm(np.diff(p, axis=0), axis=1)
    assert np.all(np.abs(steps - (s[1] - s[0])) < 0.01)


def test_centripetal_spline_has_no_cusp_with_uneven_spacing():
    control = np.array([[0.0, 0.0], [0.5, 10.0], [1.0, 0.0], [30.0, 0.0]])
    pts = catmull_rom(control, alpha=0.5, samples_per_segment=400)
    heading = np.arctan2(*np.diff(pts, axis=0)[:, ::-1].T)
    turn = np.abs(wrap_angle(np.diff(heading)))
    assert turn.max() < 0.5  # smooth: no reversal within a segment


def _catmull_rom_by_segment(control, alpha, samples):
    """The spline one segment at a time (Barry and Goldman's pyramid of blends with scalar knots):
    the reference the array version must match to the bit."""
    p = np.asarray(control, dtype=np.float64)
    ext = np.vstack([2 * p[0] - p[1], p, 2 * p[-1] - p[-2]])
    out = [p[:1]]
    u = np.linspace(0.0, 1.0, samples + 1)[1:, None]
    for i in range(len(p) - 1):
        p0, p1, p2, p3 = ext[i], ext[i + 1], ext[i + 2], ext[i + 3]
        t0 = 0.0
        t1 = t0 + max(np.linalg.norm(p1 - p0), 1e-9) ** alpha
        t2 = t1 + max(np.linalg.norm(p2 - p1), 1e-9) ** alpha
        t3 = t2 + max(np.linalg.norm(p3 - p2), 1e-9) ** alpha
        t = t1 + u * (t2 - t1)
        a1 = (t1 - t) / (t1 - t0) * p0 + (t - t0) / (t1 - t0) * p1
        a2 = (t2 - t) / (t2 - t1) * p1 + (t - t1) / (t2 - t1) * p2
        a3 = (t3 - t) / (t3 - t2) * p2 + (t - t2) / (t3 - t2) * p3
        b1 = (t2 - t) / (t2 - t0) * a1 + (t - t0) / (t2 - t0) * a2
        b2 = (t3 - t) / (t3 - t1) * a2 + (t - t1) / (t3 - t1) * a3
        c = (t2 - t) / (t2 - t1) * b1 + (t - t1) / (t2 - t1) * b2
        c[-1] = p2
        out.append(c)
    return np.vstack(out)


def test_splines_sampled_together_are_each_spline_by_segment_to_the_bit():
    rng = np.random.default_rng(11)
    for _ in range(300):
        n, k = int(rng.integers(1, 9)), int(rng.integers(2, 6))
        control = rng.normal(size=(n, k, 2)) * rng.uniform(0.05, 200)
        if rng.random() < 0.2:
            control[:, 1] = control[:, 0]  # a repeated control point (the 1e-9 knot floor)
        alpha, samples = float(rng.choice([0.0, 0.5, 1.0])), int(rng.integers(1, 70))
        together = catmull_rom_many(control, alpha, samples)
        assert together.shape == (n, 1 + (k - 1) * samples, 2)
        for i in range(n):
            alone = _catmull_rom_by_segment(control[i], alpha, samples)
            assert np.array_equal(together[i], alone)
            assert np.array_equal(catmull_rom(control[i], alpha, samples), alone)
    paths = spline_paths(control)
    for path, c in zip(paths, control):
        single = spline_path(c)
        assert np.array_equal(path.points, single.points) and np.array_equal(path.cumlen, single.cumlen)
    assert catmull_rom_many(np.zeros((0, 3, 2))).shape == (0, 129, 2)
    with pytest.raises(ValueError, match="control points"):
        catmull_rom_many(np.zeros((3, 1, 2)))


def test_path_pose_and_projection():
    path = Path.from_points(np.array([[0, 0], [10, 0], [10, 10]]))
    assert path.length == 20.0
    p, h = path.pose(15.0)
    assert np.allclose(p, [10, 5]) and h == pytest.approx(np.pi / 2)
    assert path.project(np.array([12.0, 7.0])) == pytest.approx(17.0)
    p, _ = path.pose(25.0)  # clipped to the end
    assert np.allclose(p, [10, 10])
    with pytest.raises(ValueError):
        Path.from_points(np.array([[1.0, 1.0], [1.0, 1.0]]))


def test_straight_path_and_start_pose_are_the_general_constructions_to_the_bit():
    rng = np.random.default_rng(3)
    for _ in range(2000):
        a, b = rng.normal(size=2) * rng.uniform(0, 200), rng.normal(size=2) * rng.uniform(0, 200)
        a[rng.random(2) < 0.1] = -0.0  # signed zeros survive both constructions alike
        fast, general = Path.straight(a, b), Path.from_points(np.array([a, b]))
        assert np.array_equal(fast.points, general.points) and np.array_equal(fast.cumlen, general.cumlen)
        (p, h), (q, g) = fast.start_pose(), general.pose(0.0)
        assert np.array_equal(p, q) and np.array_equal(np.signbit(p), np.signbit(q)) and h == g
    curved = spline_path(CONTROL)
    (p, h), (q, g) = curved.start_pose(), curved.pose(0.0)
    assert np.array_equal(p, q) and h == g
    with pytest.raises(ValueError, match="distinct"):
        Path.straight(np.array([1.0, 2.0]), np.array([1.0, 2.0]))


def _even_odd_by_broadcasting(points, polygon):
    """The even-odd rule as whole-array numpy (the compiled kernel's reference)."""
    x, y = points[:, 0][:, None], points[:, 1][:, None]
    xa, ya = polygon[:, 0][None, :], polygon[:, 1][None, :]
    xb, yb = np.roll(polygon[:, 0], -1)[None, :], np.roll(polygon[:, 1], -1)[None, :]
    crosses = (ya > y) != (yb > y)
    with np.errstate(divide="ignore", invalid="ignore"):
        x_at = xa + (y - ya) * (xb - xa) / (yb - ya)
    return np.sum(crosses & (x < x_at), axis=1) % 2 == 1


def test_points_in_polygon_matches_the_even_odd_rule_on_corners_edges_and_random_points():
    from box2d_driving.road.geometry import points_in_polygon

    rng = np.random.default_rng(0)
    for n_corners in (3, 4, 7, 40):
        angle = np.sort(rng.uniform(0, 2 * np.pi, n_corners))
        polygon = np.stack([np.cos(angle), np.sin(angle)], axis=1) * rng.uniform(5, 20, (n_corners, 1))
        polygon[0] = polygon[1] if n_corners == 40 else polygon[0]  # a repeated corner (zero-length edge)
        mid = 0.5 * (polygon + np.roll(polygon, -1, axis=0))
        points = np.concatenate([rng.uniform(-25, 25, (2_000, 2)), polygon, mid,
                                 np.stack([rng.uniform(-25, 25, 50), np.repeat(polygon[2, 1], 50)], axis=1),
                                 [[np.nan, 0.0], [0.0, np.nan]]])
        got = points_in_polygon(points, polygon)
        np.testing.assert_array_equal(got, _even_odd_by_broadcasting(points, polygon))
        assert 0 < got.sum() < len(points)
    assert points_in_polygon(np.zeros((0, 2)), polygon).shape == (0,)
    assert not points_in_polygon(np.zeros((3, 2)), np.zeros((0, 2))).any()


def test_points_in_box_counts_edges_and_corners_inside_and_nan_outside():
    from box2d_driving.road.geometry import points_in_box

    box = (-3.0, -2.0, 4.0, 5.0)
    rng = np.random.default_rng(1)
    points = np.concatenate([rng.uniform(-6, 7, (500, 2)), [[-3, -2], [4, 5], [-3, 5], [4, 0], [0, -2]],
                             [[-3.0000001, 0], [0, 5.0000001], [np.nan, 0.0], [0.0, np.nan]]])
    x, y = points[:, 0], points[:, 1]
    expected = (x >= -3) & (x <= 4) & (y >= -2) & (y <= 5)
    np.testing.assert_array_equal(points_in_box(points, box), expected)
    assert points_in_box(points, box)[500:505].all() and not points_in_box(points, box)[505:].any()
    assert points_in_box(np.zeros((0, 2)), box).shape == (0,)
