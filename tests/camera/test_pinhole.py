"""The pinhole camera and the shared radial-tangential distortion."""

from __future__ import annotations

import numpy as np
import pytest
from camera_checks import DISTORTED_PINHOLE

from omnislam.camera import PinholeCamera, RadialTangential
from omnislam.errors import DataError


def test_projection_of_known_points():
    camera = PinholeCamera(fx=400.0, fy=410.0, cu=319.5, cv=239.5, width=640, height=480)
    points_c = np.array([[0.0, 0.0, 2.0], [1.0, -0.5, 4.0], [0.0, 0.0, -1.0], [10.0, 0.0, 1.0]])
    pixels, valid = camera.project(points_c)
    assert np.allclose(pixels[:2], [[319.5, 239.5], [419.5, 188.25]])
    assert np.isnan(pixels[2]).all()  # behind the camera
    assert np.allclose(pixels[3], [4319.5, 239.5])  # projectable but outside the image
    assert valid.tolist() == [True, True, False, False]
    assert np.array_equal(camera.mask(), np.ones((480, 640), dtype=bool))
    assert np.allclose(camera.unproject(np.array([[319.5, 239.5]])), [[0.0, 0.0, 1.0]])


def test_image_bounds_follow_the_pixel_centre_convention():
    camera = PinholeCamera(fx=1.0, fy=1.0, cu=0.0, cv=0.0, width=4, height=3)
    inside = np.array([[-0.5, -0.5], [3.49, 2.49]])
    outside = np.array([[-0.51, 0.0], [3.5, 0.0], [0.0, 2.5]])
    assert camera.in_image(inside).all() and not camera.in_image(outside).any()


def test_distortion_jacobian_and_inverse(rng):
    distortion = RadialTangential(k1=-0.2, k2=0.05, p1=1e-3, p2=-1e-3)
    m_u = rng.uniform(-0.8, 0.8, (1_000, 2))
    m_d, J = distortion.distort(m_u)
    h = 1e-6
    for axis in range(2):
        offset = np.zeros(2)
        offset[axis] = h
        numeric = (distortion.distort(m_u + offset)[0] - distortion.distort(m_u - offset)[0]) / (
            2 * h
        )
        assert np.allclose(J[:, :, axis], numeric, rtol=1e-7, atol=1e-9)
    assert np.abs(distortion.undistort(m_d) - m_u).max() < 1e-12


def test_folded_distortion_is_not_projectable():
    # 1 + 3 k1 rho^2 = 0 at rho = 1 for k1 = -1/3: beyond, the polynomial folds back
    camera = PinholeCamera(
        fx=100.0, fy=100.0, cu=50.0, cv=50.0, width=100, height=100, k1=-1.0 / 3.0
    )
    pixels, _ = camera.project(np.array([[0.9, 0.0, 1.0], [1.2, 0.0, 1.0]]))
    assert np.isfinite(pixels[0]).all() and np.isnan(pixels[1]).all()


def test_camera_matrix():
    assert np.allclose(
        DISTORTED_PINHOLE.K,
        [[500.0, 0.2, 321.3], [0.0, 495.0, 238.7], [0.0, 0.0, 1.0]],
    )


def test_rejects_bad_sizes():
    with pytest.raises(DataError, match="width"):
        PinholeCamera(fx=1.0, fy=1.0, cu=0.0, cv=0.0, width=0, height=10)
    with pytest.raises(DataError, match="shape"):
        DISTORTED_PINHOLE.project(np.zeros((3, 2)))
