"""Analytic projection Jacobians against central differences."""

from __future__ import annotations

import numpy as np
import pytest
from camera_checks import JACOBIAN_RTOL, central_difference_jacobian, model, sample_mask_directions

ANALYTIC = ("hyperbolic", "unified-from-hyperbolic", "unified-distorted", "pinhole-distorted")


@pytest.mark.parametrize("name", ANALYTIC)
def test_analytic_jacobian_matches_central_differences(name, rng):
    camera = model(name)
    points_c = sample_mask_directions(camera, 2_000, rng) * rng.uniform(0.2, 50.0, (2_000, 1))
    analytic = camera.project_jacobian(points_c)
    numeric = central_difference_jacobian(camera, points_c)
    scale = np.linalg.norm(numeric, axis=(1, 2))
    error = np.linalg.norm(analytic - numeric, axis=(1, 2)) / scale
    assert error.max() <= JACOBIAN_RTOL
    # the point's own direction is in the null space: only the direction matters
    assert np.abs(np.einsum("nij,nj->ni", analytic, points_c)).max() <= 1e-9 * scale.max()


@pytest.mark.parametrize("name", ["ocamcalib-office-like"])
def test_numerical_jacobian_predicts_small_motions(name, rng):
    camera = model(name)
    points_c = sample_mask_directions(camera, 500, rng) * 3.0
    J = camera.project_jacobian(points_c)
    delta = rng.normal(0.0, 1e-4, points_c.shape)
    moved, _ = camera.project(points_c + delta)
    predicted = camera.project(points_c)[0] + np.einsum("nij,nj->ni", J, delta)
    assert np.abs(moved - predicted).max() < 1e-3  # second-order remainder at 0.1 mm on 3 m


def test_jacobian_is_nan_where_not_projectable():
    camera = model("hyperbolic")
    J = camera.project_jacobian(np.array([[0.0, 0.0, 1.0]]))  # above the asymptote
    assert np.isnan(J).all()
    J = model("pinhole-distorted").project_jacobian(np.array([[0.0, 0.0, -1.0]]))
    assert np.isnan(J).all()
