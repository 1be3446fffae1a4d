"""NEES: a consistent estimator's mean NEES is its dimension; yaw residuals wrap."""

import numpy as np
import pytest

from omnislam.core.types import Trajectory
from omnislam.metrics.consistency import nees, pose_nees


def test_nees_of_a_consistent_estimator_is_its_dimension():
    rng = np.random.default_rng(50)
    n = 4000
    A = rng.normal(size=(n, 3, 3)) * [0.3, 0.2, 0.05]
    cov = A @ np.swapaxes(A, 1, 2) + 1e-4 * np.eye(3)
    errors = np.einsum("kij,kj->ki", np.linalg.cholesky(cov), rng.normal(size=(n, 3)))
    result = nees(errors, cov)
    assert result.dof == 3 and result.mean == pytest.approx(3.0, rel=0.05)
    assert result.anees == pytest.approx(1.0, rel=0.05)
    assert result.within_bounds == pytest.approx(0.95, abs=0.015)
    assert nees(2.0 * errors, cov).anees == pytest.approx(4.0, rel=0.06)  # overconfident


def test_pose_nees_wraps_the_yaw_residual_and_skips_singular_covariances():
    stamps = np.arange(4, dtype=float)
    truth = np.array([[0, 0, 0], [1, 0, np.pi - 0.01], [2, 0, -np.pi + 0.01], [3, 0, 0.0]])
    est = truth.copy()
    est[1:, 2] = [-np.pi + 0.01, np.pi - 0.01, 0.0]  # 0.02 rad off across the cut
    cov = np.tile(np.diag([0.01, 0.01, 0.02**2]), (4, 1, 1))
    cov[0] = 0.0  # the anchored first pose: no uncertainty
    result = pose_nees(Trajectory.from_se2(stamps, est), cov, Trajectory.from_se2(stamps, truth))
    assert result.skipped == 1
    assert result.values == pytest.approx([1.0, 1.0, 0.0], abs=1e-9)
