"""The filter's pose spread relative to its maps (``fastslam/pose_spread.py``)."""

from __future__ import annotations

import numpy as np

from omnislam.core.measurement import RangeBearing2D
from omnislam.fastslam.pose_spread import PoseSpread

#: one step's covariance in the robot frame (5 cm, 5 cm, 0.02 rad)
STEP_COV = np.diag([0.05**2, 0.05**2, 0.02**2])


def test_prediction_composes_like_the_odometry():
    """Driving 1 m straight in 10 steps: the heading variance adds up, and the lateral variance
    picks up the heading's lever arm (sum of the squared distances still to drive)."""
    spread = PoseSpread(1.0)
    for k in range(10):
        spread.predict(np.array([0.1 * k, 0.0, 0.0]), np.array([0.1 * (k + 1), 0.0, 0.0]), STEP_COV)
    C = spread.covariance
    np.testing.assert_allclose(C[2, 2], 10 * STEP_COV[2, 2], rtol=1e-6)
    np.testing.assert_allclose(C[0, 0], 10 * STEP_COV[0, 0], rtol=1e-6)
    lever = sum((0.1 * j) ** 2 for j in range(1, 10))  # heading error of step k moves the end
    np.testing.assert_allclose(C[1, 1], 10 * STEP_COV[1, 1] + STEP_COV[2, 2] * lever, rtol=1e-6)


def test_sightings_shrink_it_and_more_particles_weigh_the_same():
    """A sighting's information shrinks the covariance; the same sighting in two particles of
    half the weight each gives the same covariance as in one particle of full weight."""
    model = RangeBearing2D()
    results = []
    for who, weights in (
        (np.array([0]), np.array([1.0])),
        (np.array([0, 1]), np.array([0.5, 0.5])),
    ):
        spread = PoseSpread(1.0)
        for _ in range(20):
            spread.predict(np.array([0.0, 0.0, 0.0]), np.array([0.0, 0.0, 0.0]), STEP_COV)
        before = spread.covariance.copy()
        n = who.size
        spread.update(
            model,
            np.zeros((n, 3)),
            np.tile([3.0, 1.0], (n, 1)),
            np.tile(np.eye(2) * 1e-4, (n, 1, 1)),
            np.tile(np.diag([0.06**2, 0.011**2]), (n, 1, 1)),
            who,
            weights,
        )
        assert np.trace(spread.covariance) < 0.5 * np.trace(before)
        assert np.all(np.linalg.eigvalsh(spread.covariance) > 0)
        results.append(spread.covariance)
    np.testing.assert_allclose(results[0], results[1], rtol=1e-9)


def test_the_association_adds_the_scaled_covariance_to_every_particle():
    spread = PoseSpread(30.0)
    spread.predict(np.zeros(3), np.array([1.0, 0.0, 0.0]), STEP_COV)
    out = spread.world_frame(4)
    assert out.shape == (4, 3, 3)
    np.testing.assert_allclose(out[3], 30.0 * spread.covariance)
