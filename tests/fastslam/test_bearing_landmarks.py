"""Triangulated pseudo-measurements of the thesis's 3-D landmark life cycle."""

from __future__ import annotations

import numpy as np

from omnislam.core.measurement import RangeAzimuthElevation3D
from omnislam.fastslam.bearing_landmarks import (
    first_estimate,
    triangulate,
    triangulated_measurement,
    world_rays,
)
from omnislam.fastslam.config import TriangulationMethod

HEIGHT_M = 0.85


def _two_views(rng, n=6):
    landmarks = np.column_stack([rng.uniform(2, 4, (n, 2)), rng.uniform(0.2, 2.5, n)])
    poses_a = np.column_stack([rng.uniform(-0.5, 0.5, (n, 2)), rng.uniform(-np.pi, np.pi, n)])
    poses_b = poses_a + np.array([0.4, 0.1, 0.2])
    model = RangeAzimuthElevation3D(HEIGHT_M)

    def unit_vectors(poses):
        z, _, _ = model.predict(poses, landmarks)
        c = np.cos(z[:, 2])
        return np.column_stack([c * np.cos(z[:, 1]), c * np.sin(z[:, 1]), np.sin(z[:, 2])])

    rays_a = world_rays(poses_a, unit_vectors(poses_a), HEIGHT_M)
    rays_b = world_rays(poses_b, unit_vectors(poses_b), HEIGHT_M)
    return model, landmarks, poses_b, rays_a, rays_b


def test_noise_free_rays_triangulate_the_landmark(rng):
    model, landmarks, poses_b, rays_a, rays_b = _two_views(rng)
    points, valid, parallax = triangulate(TriangulationMethod.MIDPOINT, rays_a, rays_b)
    assert valid.all() and np.all(parallax > 0)
    np.testing.assert_allclose(points, landmarks, atol=1e-9)
    sigma = np.full(len(points), 0.004)
    z, Q = triangulated_measurement(model, poses_b, points, sigma, parallax)
    mean, _ = first_estimate(model, poses_b, z, Q)
    np.testing.assert_allclose(mean, landmarks, atol=1e-9)


def test_ray_reuse_inflates_the_pseudo_measurement_noise(rng):
    """Each ray enters two triangulations, so Q (and the first covariance, eq. 4.27) doubles;
    the measured z itself is unchanged."""
    model, _, poses_b, rays_a, rays_b = _two_views(rng)
    points, _, parallax = triangulate(TriangulationMethod.MIDPOINT, rays_a, rays_b)
    sigma = np.full(len(points), 0.004)
    z1, Q1 = triangulated_measurement(model, poses_b, points, sigma, parallax)
    z2, Q2 = triangulated_measurement(model, poses_b, points, sigma, parallax, 2.0)
    np.testing.assert_array_equal(z1, z2)
    np.testing.assert_allclose(Q2, 2.0 * Q1)
    _, cov1 = first_estimate(model, poses_b, z1, Q1)
    _, cov2 = first_estimate(model, poses_b, z2, Q2)
    np.testing.assert_allclose(cov2, 2.0 * cov1)
