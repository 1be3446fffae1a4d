import numpy as np
import pytest

from omnislam.core.triangulation import (
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
