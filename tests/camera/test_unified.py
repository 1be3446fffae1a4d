"""The unified sphere model, and its equivalence with the hyperbolic-mirror camera."""

from __future__ import annotations

import numpy as np
import pytest
from camera_checks import (
    DISTORTED_PINHOLE,
    N_SAMPLES,
    PIXEL_TOL_PX,
    RAY_TOL_RAD,
    angle_between,
    sample_mask_directions,
    sample_mask_pixels,
)
from hypothesis import given, settings
from hypothesis import strategies as st

from omnislam.camera import HyperbolicCamera, UnifiedCamera, hyperbolic_to_unified
from omnislam.errors import DataError

MIRRORS = st.builds(
    HyperbolicCamera,
    a_m=st.floats(0.01, 0.05),
    b_m=st.floats(0.01, 0.05),
    focal_length_m=st.floats(2e-3, 12e-3),
    cu=st.floats(300.0, 340.0),
    cv=st.floats(300.0, 340.0),
)


@settings(max_examples=5, deadline=None)
@given(h=MIRRORS, seed=st.integers(0, 2**32 - 1))
def test_hyperbolic_and_unified_project_identically(h, seed):
    u, R_us = hyperbolic_to_unified(h)
    rng = np.random.default_rng(seed)
    directions_s = rng.normal(size=(N_SAMPLES, 3))
    pixels_h, valid_h = h.project(directions_s)
    pixels_u, valid_u = u.project(directions_s @ R_us.T)
    seen = np.all(np.isfinite(pixels_h), axis=1)  # inside the mirror's asymptotic cone
    assert seen.sum() > N_SAMPLES // 2
    assert np.abs(pixels_h[seen] - pixels_u[seen]).max() <= PIXEL_TOL_PX
    assert np.array_equal(valid_h[seen], valid_u[seen])


@settings(max_examples=5, deadline=None)
@given(h=MIRRORS, seed=st.integers(0, 2**32 - 1))
def test_hyperbolic_and_unified_unproject_identically(h, seed):
    u, R_us = hyperbolic_to_unified(h)
    pixels = np.random.default_rng(seed).uniform(0.0, 640.0, (N_SAMPLES, 2))
    rays_h = h.unproject(pixels)
    seen = np.all(np.isfinite(rays_h), axis=1)
    rays_u_in_s = u.unproject(pixels[seen]) @ R_us  # R_us^T maps back to S
    assert angle_between(rays_h[seen], rays_u_in_s).max() <= RAY_TOL_RAD


def test_equivalence_parameters_match_the_textbook_formulas():
    h = HyperbolicCamera()
    u, R_us = hyperbolic_to_unified(h)
    d = 2.0 * h.e_m  # distance between the foci
    p = (2.0 * h.b_m**2 / h.a_m) / 4.0  # the latus rectum is 4p = 2 b^2 / a
    root = np.sqrt(d**2 + 4.0 * p**2)
    assert u.xi == pytest.approx(d / root, rel=1e-14)
    assert u.gamma1 == pytest.approx(h.focal_px * 2.0 * p / root, rel=1e-14)
    assert 0.0 < u.xi < 1.0 and u.xi > h.a_m / h.e_m
    assert np.linalg.det(R_us) == pytest.approx(-1.0)  # a reflection: the image is mirrored
    assert np.array_equal(u.mask(), h.mask())


def test_xi_zero_is_the_pinhole_camera(rng):
    p = DISTORTED_PINHOLE
    u = UnifiedCamera(
        xi=0.0,
        gamma1=p.fx,
        gamma2=p.fy,
        cu=p.cu,
        cv=p.cv,
        width=p.width,
        height=p.height,
        skew=p.skew,
        k1=p.k1,
        k2=p.k2,
        p1=p.p1,
        p2=p.p2,
    )
    points_c = sample_mask_directions(p, 2_000, rng) * rng.uniform(0.5, 20.0, (2_000, 1))
    assert np.allclose(u.project(points_c)[0], p.project(points_c)[0], atol=1e-9)
    pixels = sample_mask_pixels(p, 2_000, rng)
    assert angle_between(u.unproject(pixels), p.unproject(pixels)).max() < 1e-12


@pytest.mark.parametrize(("xi", "z_limit"), [(0.5, -0.5), (1.0, -1.0), (1.6, -1.0 / 1.6)])
def test_validity_limit_on_the_sphere(xi, z_limit):
    u = UnifiedCamera(
        xi=xi, gamma1=100.0, gamma2=100.0, cu=500.0, cv=500.0, width=1000, height=1000
    )

    def direction(z):
        return np.array([[np.sqrt(1 - z**2), 0.0, z]])

    if z_limit > -1.0:
        assert not u.project(direction(z_limit - 1e-3))[1][0]
        assert np.isnan(u.project(direction(z_limit - 1e-3))[0]).all()
    pixels, _ = u.project(direction(z_limit + 0.2))
    assert np.isfinite(pixels).all()
    assert angle_between(u.unproject(pixels), direction(z_limit + 0.2))[0] < 1e-12


def test_xi_above_one_has_a_bounded_image():
    u = UnifiedCamera(
        xi=1.6, gamma1=100.0, gamma2=100.0, cu=500.0, cv=500.0, width=1000, height=1000
    )
    r_max = 100.0 / np.sqrt(1.6**2 - 1.0)  # |m| <= 1 / sqrt(xi^2 - 1)
    rays = u.unproject(np.array([[500.0 + 0.99 * r_max, 500.0], [500.0 + 1.01 * r_max, 500.0]]))
    assert np.isfinite(rays[0]).all() and np.isnan(rays[1]).all()


def test_parameters_are_validated():
    with pytest.raises(DataError, match="gamma1"):
        UnifiedCamera(xi=1.0, gamma1=0.0, gamma2=1.0, cu=0.0, cv=0.0, width=10, height=10)
    with pytest.raises(DataError, match="xi"):
        UnifiedCamera(xi=-0.1, gamma1=1.0, gamma2=1.0, cu=0.0, cv=0.0, width=10, height=10)
    with pytest.raises(DataError, match="mask radii"):
        UnifiedCamera(
            xi=1.0,
            gamma1=1.0,
            gamma2=1.0,
            cu=0.0,
            cv=0.0,
            width=10,
            height=10,
            inner_radius_px=5.0,
            outer_radius_px=4.0,
        )
