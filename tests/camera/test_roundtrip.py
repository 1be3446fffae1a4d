"""Property tests: project and unproject invert each other over every model's usable region."""

from __future__ import annotations

import numpy as np
import pytest
from camera_checks import (
    MODEL_NAMES,
    N_SAMPLES,
    PIXEL_TOL_PX,
    RAY_TOL_RAD,
    angle_between,
    model,
    sample_mask_directions,
    sample_mask_pixels,
)
from hypothesis import given, settings
from hypothesis import strategies as st

from omnislam.camera import UnifiedCamera

SEEDS = st.integers(min_value=0, max_value=2**32 - 1)


@pytest.mark.parametrize("name", MODEL_NAMES)
@settings(max_examples=10, deadline=None)
@given(seed=SEEDS)
def test_project_of_unproject_returns_the_pixel(name, seed):
    camera = model(name)
    pixels = sample_mask_pixels(camera, N_SAMPLES, np.random.default_rng(seed))
    rays_c = camera.unproject(pixels)
    assert np.allclose(np.linalg.norm(rays_c, axis=1), 1.0, atol=1e-12)
    again, valid = camera.project(rays_c)
    assert valid.all()
    assert np.abs(again - pixels).max() <= PIXEL_TOL_PX


@pytest.mark.parametrize("name", MODEL_NAMES)
@settings(max_examples=10, deadline=None)
@given(seed=SEEDS, distance_m=st.floats(min_value=0.01, max_value=1e4))
def test_unproject_of_project_returns_the_direction(name, seed, distance_m):
    camera = model(name)
    rays_c = sample_mask_directions(camera, N_SAMPLES, np.random.default_rng(seed))
    pixels, valid = camera.project(distance_m * rays_c)
    assert valid.all()
    assert angle_between(camera.unproject(pixels), rays_c).max() <= RAY_TOL_RAD


@settings(max_examples=15, deadline=None)
@given(
    seed=SEEDS,
    xi=st.floats(0.8, 1.0),
    gamma=st.floats(220.0, 300.0),
    aspect=st.floats(0.98, 1.02),
    k1=st.floats(-0.05, 0.05),
    k2=st.floats(-0.003, 0.003),
    p1=st.floats(-5e-4, 5e-4),
    p2=st.floats(-5e-4, 5e-4),
    skew=st.floats(-1.0, 1.0),
)
def test_unified_round_trip_over_distortion_parameters(
    seed, xi, gamma, aspect, k1, k2, p1, p2, skew
):
    camera = UnifiedCamera(
        xi=xi,
        gamma1=gamma,
        gamma2=gamma * aspect,
        cu=320.0,
        cv=318.0,
        width=640,
        height=640,
        skew=skew,
        k1=k1,
        k2=k2,
        p1=p1,
        p2=p2,
        inner_radius_px=40.0,
        outer_radius_px=300.0,
    )
    rng = np.random.default_rng(seed)
    pixels = sample_mask_pixels(camera, 2_000, rng)
    again, valid = camera.project(camera.unproject(pixels))
    assert valid.all()
    assert np.abs(again - pixels).max() <= PIXEL_TOL_PX
