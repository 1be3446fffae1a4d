import numpy as np
import pytest

from omnislam.core.triangulation import (
    PARALLEL_SIN,
    floor_points_r,
    triangulate_ground_plane,
    triangulate_midpoint,
    triangulate_rays,
)


def _rays(rng, n):
    points = rng.uniform([-5, -5, 0.0], [5, 5, 3.0], (n, 3))
    o1 = np.c_[rng.uniform(-5, 5, (n, 2)), np.full(n, 0.4)]
    o2 = o1 + np.c_[rng.uniform(-1, 1, (n, 2)), np.zeros(n)]
    return points, o1, points - o1, o2, points - o2


@pytest.mark.parametrize("method", [triangulate_ground_plane, triangulate_midpoint])
def test_exact_rays_recover_the_point(rng, method):
    points, o1, d1, o2, d2 = _rays(rng, 500)
    estimate, valid = method(o1, d1, o2, d2)
    # the ground-plane method cannot resolve rays whose projections are nearly parallel
    assert valid.mean() > 0.95
    np.testing.assert_allclose(estimate[valid], points[valid], atol=1e-6)


def test_ground_plane_method_rejects_parallel_and_backward_rays():
    o1, o2 = np.array([0.0, 0, 0]), np.array([1.0, 0, 0])
    ahead = np.array([1.0, 0, 0.1])
    _, valid = triangulate_ground_plane(o1, ahead, o2, ahead)
    assert not valid
    _, valid = triangulate_ground_plane(o1, np.array([1.0, 1, 0]), o2, np.array([1.0, -1, 0]))
    assert not valid, "the lines cross behind the second origin"


def test_noisy_rays_least_squares_beats_two_ray_methods(rng):
    """With noise on every ray, using all K rays is more accurate than any two of them."""
    truth = np.array([3.0, 1.0, 1.5])
    errors = {"ground": [], "midpoint": [], "lsq": []}
    for _ in range(300):
        origins = np.c_[np.linspace(-1.0, 1.0, 6), np.full(6, -1.0), np.full(6, 0.4)]
        directions = truth - origins
        directions /= np.linalg.norm(directions, axis=1, keepdims=True)
        directions += rng.normal(0, 0.005, directions.shape)
        errors["ground"].append(
            np.linalg.norm(
                triangulate_ground_plane(origins[0], directions[0], origins[-1], directions[-1])[0]
                - truth
            )
        )
        errors["midpoint"].append(
            np.linalg.norm(
                triangulate_midpoint(origins[0], directions[0], origins[-1], directions[-1])[0]
                - truth
            )
        )
        errors["lsq"].append(np.linalg.norm(triangulate_rays(origins, directions).point_w - truth))
    rms = {k: float(np.sqrt(np.mean(np.square(v)))) for k, v in errors.items()}
    assert rms["lsq"] < rms["midpoint"]
    assert rms["lsq"] < rms["ground"]


def test_triangulate_rays_reports_parallax_and_conditioning():
    origins = np.array([[0.0, 0, 0], [1.0, 0, 0]])
    point = np.array([0.5, 4.0, 1.0])
    result = triangulate_rays(origins, point - origins)
    np.testing.assert_allclose(result.point_w, point, atol=1e-12)
    assert result.in_front
    unit = (point - origins) / np.linalg.norm(point - origins, axis=1)[:, None]
    assert result.parallax_rad == pytest.approx(np.arccos(unit[0] @ unit[1]))
    parallel = triangulate_rays(origins, np.array([[0.0, 1, 0], [0.0, 1, 0]]))
    assert parallel.min_eigenvalue < 1e-12
    with pytest.raises(ValueError):
        triangulate_rays(origins[:1], origins[:1])


def test_midpoint_rejects_backward_and_near_parallel_rays():
    o1, o2 = np.array([0.0, 0, 0]), np.array([1.0, 0, 0])
    # the lines cross at (0.5, 0.5, 0): ahead of the first origin, behind the second
    point, valid = triangulate_midpoint(o1, np.array([1.0, 1, 0]), o2, np.array([1.0, -1, 0]))
    np.testing.assert_allclose(point, [0.5, 0.5, 0.0], atol=1e-12)
    assert not valid, "the lines cross behind the second origin"
    point, valid = triangulate_midpoint(o2, np.array([1.0, -1, 0]), o1, np.array([1.0, 1, 0]))
    assert not valid, "the lines cross behind the first origin"
    # rays 1 m apart converging at a tenth of the parallel threshold's angle (1 - cos^2 is
    # sin^2 of it): they meet ahead of both origins, far out, and are rejected as parallel
    angle = 0.1 * np.sqrt(PARALLEL_SIN)
    o3 = np.array([0.0, 1.0, 0.0])
    _, valid = triangulate_midpoint(o1, np.array([1.0, 0, 0]), o3, np.array([1.0, -angle, 0]))
    assert not valid


def test_ground_plane_height_is_the_mean_of_both_rays_heights():
    """Skew rays: the ground projections cross at (1, 1), where ray 1 is at height 0 and ray
    2 at height 1 (t1 = t2 = 1): eq. 4.21's z is their mean."""
    point, valid = triangulate_ground_plane(
        np.array([0.0, 0, 0]), np.array([1.0, 1, 0]), np.array([2.0, 0, 1]), np.array([-1.0, 1, 0])
    )
    assert valid
    np.testing.assert_allclose(point, [1.0, 1.0, 0.5], atol=1e-12)


def test_floor_points_and_their_radial_std():
    """A bearing depressed by delta from a viewpoint h up meets the floor at h / tan(delta);
    d(range)/d(delta) = -h / sin^2(delta), so an angular std sigma gives h sigma / sin^2."""
    h, sigma = 0.45, 0.002
    depression = np.array([0.1, 0.4, 0.9, 1.4])
    azimuth = np.array([0.0, 1.0, -2.0, 3.0])
    u = np.c_[np.cos(depression) * np.cos(azimuth), np.cos(depression) * np.sin(azimuth)]
    u = np.c_[u, -np.sin(depression)]
    points, stds = floor_points_r(u, np.full(4, sigma), h)
    ranges = h / np.tan(depression)
    np.testing.assert_allclose(points, ranges[:, None] * np.c_[np.cos(azimuth), np.sin(azimuth)])
    step = 1e-6
    slope = (h / np.tan(depression - step) - h / np.tan(depression + step)) / (2 * step)
    np.testing.assert_allclose(stds, sigma * slope, rtol=1e-8)
