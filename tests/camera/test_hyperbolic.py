"""The hyperbolic-mirror camera: geometry of thesis 4.3, frame, mask and angular noise."""

from __future__ import annotations

import math

import numpy as np
import pytest
from camera_checks import angle_between, sample_mask_directions, sample_mask_pixels

from omnislam.camera import HyperbolicCamera, hyperbolic_to_unified
from omnislam.errors import DataError


@pytest.fixture(scope="module")
def camera() -> HyperbolicCamera:
    return HyperbolicCamera()


def test_mirror_points_lie_on_the_sheet_around_f2_and_obey_the_law_of_reflection(camera, rng):
    a, b, e = camera.a_m, camera.b_m, camera.e_m
    rays_s = sample_mask_directions(camera, 5_000, rng)
    P = camera.mirror_point(rays_s)
    residual = (P[:, 2] + e) ** 2 / a**2 - (P[:, 0] ** 2 + P[:, 1] ** 2) / b**2 - 1.0
    assert np.abs(residual).max() < 1e-12
    assert np.all(P[:, 2] + e >= a)  # the sheet around F2, not the virtual one around F1
    # Light travelling towards F2 (direction -r) reflects about the surface normal and must
    # then travel towards the pinhole F1 = (0, 0, -2e).
    normal = np.column_stack([-P[:, 0] / b**2, -P[:, 1] / b**2, (P[:, 2] + e) / a**2])
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    incoming = -rays_s
    reflected = incoming - 2.0 * np.einsum("ij,ij->i", incoming, normal)[:, None] * normal
    towards_f1 = np.array([0.0, 0.0, -2.0 * e]) - P
    assert angle_between(reflected, towards_f1).max() < 1e-12


def test_unproject_follows_thesis_eq_4_19_with_the_larger_root(camera, rng):
    pixels = sample_mask_pixels(camera, 2_000, rng)
    s, f, a, b, z_h = (
        camera.pixel_size_m,
        camera.focal_length_m,
        camera.a_m,
        camera.b_m,
        camera.z_h_m,
    )
    i = (pixels[:, 0] - camera.cu) * s
    j = (pixels[:, 1] - camera.cv) * s
    k = np.full_like(i, f)
    # Thesis eq. 4.19 written out with the line's origin at F1 (x_v = y_v = z_v = 0).
    A = (k / a) ** 2 - (i / b) ** 2 - (j / b) ** 2
    B = 2.0 * (-k * z_h / a**2)
    C = (z_h / a) ** 2 - 1.0
    roots = np.stack(
        [(-B + np.sqrt(B**2 - 4 * A * C)) / (2 * A), (-B - np.sqrt(B**2 - 4 * A * C)) / (2 * A)]
    )
    assert np.all(roots > 0)  # two crossings: the virtual sheet first, then the mirror
    P_f1 = roots[0][:, None] * np.column_stack([i, j, k])  # thesis frame: origin at F1
    F2_f1 = np.array([0.0, 0.0, 2.0 * z_h])
    expected = (P_f1 - F2_f1) / np.linalg.norm(P_f1 - F2_f1, axis=1, keepdims=True)
    assert angle_between(camera.unproject(pixels), expected).max() < 1e-12


def test_frame_convention(camera):
    centre = camera.unproject(np.array([[camera.cu, camera.cv]]))
    assert np.allclose(centre, [[0.0, 0.0, -1.0]], atol=1e-15)  # the camera's own reflection
    pixels, valid = camera.project(np.array([[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]))
    assert valid.all()
    assert pixels[0, 0] > camera.cu and pixels[0, 1] == pytest.approx(camera.cv)  # +x -> +u
    assert pixels[1, 1] > camera.cv and pixels[1, 0] == pytest.approx(camera.cu)  # +y -> +v


def test_default_mirror_fills_the_image_and_sees_above_the_horizon(camera):
    horizon_px = camera.radius_px_of_elevation(np.array([0.0]))[0]
    assert camera.inner_radius_px < horizon_px < camera.outer_radius_px <= camera.width / 2
    assert camera.outer_radius_px > 0.9 * camera.width / 2
    assert math.radians(15) < camera.max_elevation_rad < math.radians(30)
    assert camera.max_elevation_rad < camera.asymptote_elevation_rad
    # the rim's elevation, computed from the rim radius, images exactly at the outer radius
    rim = camera.radius_px_of_elevation(np.array([camera.max_elevation_rad]))[0]
    assert rim == pytest.approx(camera.outer_radius_px, rel=1e-12)


def test_mask_is_the_ring_between_the_camera_reflection_and_the_rim(camera):
    mask = camera.mask()
    assert mask.shape == (camera.height, camera.width) and mask.dtype == bool
    v, u = np.nonzero(mask)
    radius_px = np.hypot(u - camera.cu, v - camera.cv)
    assert radius_px.min() >= camera.inner_radius_px
    assert radius_px.max() <= camera.outer_radius_px
    ring_area = math.pi * (camera.outer_radius_px**2 - camera.inner_radius_px**2)
    assert mask.sum() == pytest.approx(ring_area, rel=0.01)
    assert not camera.in_mask(np.array([[camera.cu, camera.cv]]))[0]


def test_directions_above_the_asymptote_are_not_projectable(camera):
    steep = np.array([[0.1, 0.0, 1.0], [0.0, 0.0, 1.0]])
    pixels, valid = camera.project(steep)
    assert not valid.any() and np.isnan(pixels).all()
    assert not camera.project(np.zeros((1, 3)))[1][0]


def test_non_central_mirror_is_rejected():
    e = HyperbolicCamera().e_m
    assert HyperbolicCamera(z_h_m=e).z_h_m == e
    with pytest.raises(DataError, match="non-central"):
        HyperbolicCamera(z_h_m=1.01 * e)


def test_angular_sigma_matches_closed_form_and_shrinks_towards_the_rim(camera):
    """Pixel noise costs *less* angle towards the rim for this geometry.

    Tangential resolution is gamma / (xi - sin(phi)) px/rad and radial resolution
    gamma (1 - xi sin(phi)) / (xi - sin(phi))^2 >= tangential (0 < xi < 1), so the worst-case
    angular std is sigma_px (xi - sin(phi)) / gamma: it *falls* monotonically from the inner
    to the outer mask radius. The thesis's loss of resolution at the rim (3.6) is a loss of
    *ground* resolution: at low elevations a small angle error is a large range error.
    """
    unified, _ = hyperbolic_to_unified(camera)
    radius_px = np.linspace(camera.inner_radius_px, camera.outer_radius_px, 200)
    pixels = np.column_stack([camera.cu + radius_px, np.full_like(radius_px, camera.cv)])
    sigma_rad = camera.angular_sigma(pixels, sigma_px=0.5)
    elevation_rad = np.arcsin(camera.unproject(pixels)[:, 2])
    expected = 0.5 * (unified.xi - np.sin(elevation_rad)) / unified.gamma1
    assert np.allclose(sigma_rad, expected, rtol=1e-7)
    assert np.all(np.diff(sigma_rad) < 0)
    assert sigma_rad[0] / sigma_rad[-1] == pytest.approx(2.94, abs=0.01)


def test_ray_covariance_matches_monte_carlo(camera, rng):
    for radius_px in (70.0, 180.0, 290.0):
        pixel = np.array([[camera.cu + 0.6 * radius_px, camera.cv - 0.8 * radius_px]])
        ray = camera.unproject(pixel)[0]
        cov = camera.ray_covariance(pixel, sigma_px=0.3)[0]
        noisy = camera.unproject(pixel + rng.normal(0.0, 0.3, (40_000, 2)))
        sample_cov = np.cov((noisy - ray).T)
        assert np.trace(sample_cov) == pytest.approx(np.trace(cov), rel=0.03)
        assert abs(ray @ cov @ ray) < 1e-12 * np.trace(cov)  # rank 2: no spread along the ray
