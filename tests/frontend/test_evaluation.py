"""Evaluation against ground truth: the bearing-noise ratio on residuals of known spread."""

from __future__ import annotations

import numpy as np
import pytest

from omnislam.frontend.evaluation import BearingResiduals, noise_ratio, noise_ratio_median


def _residuals(rng, sigma_true, sigma_logged, n=18000, track_size=None):
    """Angles of 2-D Gaussian tangent errors of std ``sigma_true`` per axis."""
    error = rng.normal(scale=sigma_true, size=(n, 2))
    dof = np.ones(n)
    if track_size is not None:  # residuals around the mean of each track's own sightings
        error = error.reshape(-1, track_size, 2)
        error = (error - error.mean(axis=1, keepdims=True)).reshape(-1, 2)
        dof = np.full(n, track_size / (track_size - 1.0))
    return BearingResiduals(np.hypot(error[:, 0], error[:, 1]), np.full(n, sigma_logged), dof,
                            np.repeat(np.arange(n // (track_size or 1)), track_size or 1))


@pytest.mark.parametrize("track_size", [None, 3, 6])
def test_the_noise_ratio_is_one_when_sigma_is_right_and_scales_with_it(track_size):
    rng = np.random.default_rng(0)
    right = _residuals(rng, 0.002, 0.002, track_size=track_size)
    assert noise_ratio(right) == pytest.approx(1.0, abs=0.03)
    assert noise_ratio_median(right) == pytest.approx(1.0, abs=0.05 if track_size else 0.03)
    too_large = _residuals(rng, 0.002, 0.01, track_size=track_size)
    assert noise_ratio(too_large) == pytest.approx(0.2, abs=0.01)


def test_gross_errors_beyond_the_trim_do_not_move_the_ratio():
    rng = np.random.default_rng(1)
    res = _residuals(rng, 0.002, 0.002)
    angles = res.angle_rad.copy()
    angles[:100] = 1.0  # 0.5 % wrong associations
    spoiled = BearingResiduals(angles, res.sigma_rad, res.dof, res.track)
    assert noise_ratio(spoiled) == pytest.approx(1.0, abs=0.03)
    assert noise_ratio(spoiled, trim=0.0) > 10
