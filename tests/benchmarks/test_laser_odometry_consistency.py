"""``benchmarks/laser_odometry.py --consistency``: errors drawn from their stated covariances read
as consistent (z std 1, NEES chi-square with 3 dof), a heading std stated half as wide reads as
z theta std 2, and the steps fall into the bands of their rotation."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[2]
_spec = importlib.util.spec_from_file_location(
    "laser_odometry_benchmark", REPO / "benchmarks" / "laser_odometry.py"
)
benchmark = importlib.util.module_from_spec(_spec)
sys.modules["laser_odometry_benchmark"] = benchmark
_spec.loader.exec_module(benchmark)

STEPS = 20000
Z_STD_TOL = 0.03  # the std of a sample std over 20000 normal draws is 0.005
NEES_TOL = 0.1  # of the mean 3 (its std over 20000 draws: 0.017) and of the median 2.37


def _steps(rng: np.random.Generator) -> benchmark.Consistency:
    """Errors drawn from random correlated covariances of laser-odometry size."""
    A = rng.normal(size=(STEPS, 3, 3)) * np.array([0.02, 0.02, 0.004])[:, None]
    covariances = A @ A.transpose(0, 2, 1) + np.diag([1e-4, 1e-4, 1e-6])
    errors = np.einsum("nij,nj->ni", np.linalg.cholesky(covariances), rng.normal(size=(STEPS, 3)))
    return benchmark.Consistency(errors, covariances, rng.uniform(-0.8, 0.8, STEPS))


def test_errors_drawn_from_the_stated_covariance_read_as_consistent():
    summary = _steps(np.random.default_rng(0)).summary()
    assert summary.steps == STEPS
    np.testing.assert_allclose(summary.z_std, 1.0, atol=Z_STD_TOL)
    assert summary.nees_mean == pytest.approx(3.0, abs=NEES_TOL)
    assert summary.nees_median == pytest.approx(2.366, abs=NEES_TOL)
    assert summary.beyond_3_theta == pytest.approx(0.0027, abs=0.0015)


def test_a_heading_std_stated_half_as_wide_reads_as_z_theta_std_2():
    steps = _steps(np.random.default_rng(1))
    halved = steps.covariances.copy()
    halved[:, 2, :] /= 2  # the heading's std halved, its correlations kept
    halved[:, :, 2] /= 2
    summary = benchmark.Consistency(steps.errors, halved, steps.rotations_rad).summary()
    np.testing.assert_allclose(summary.z_std, [1.0, 1.0, 2.0], atol=2 * Z_STD_TOL)
    assert summary.nees_mean > 3.0 + 10 * NEES_TOL
    assert summary.beyond_3_theta > 0.1  # P(|N(0, 4)| > 3) = 0.134


def test_steps_fall_into_the_bands_of_their_rotation():
    rotations_deg = np.array([1, -2, 4.9, 5, -14, 20, 29, -31, 90, 100])
    steps = benchmark.Consistency(
        np.zeros((10, 3)), np.broadcast_to(np.eye(3), (10, 3, 3)), np.radians(rotations_deg)
    )
    counts = {band: n for band, n, _ in steps.rows()}
    assert counts == {"all": 10, "0-5 deg": 3, "5-15 deg": 2, "15-30 deg": 2, "30-180 deg": 3}
    assert steps.summary(np.arange(10) < 4) is None  # fewer than 5 steps: no statistics
