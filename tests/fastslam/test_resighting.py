"""The pose spread since a landmark's last sighting (``fastslam/resighting.py``) and the
association that uses it (``association.maximum_likelihood_association``)."""

from __future__ import annotations

import numpy as np
import pytest

from omnislam.core.gating import chi_square_gate
from omnislam.core.measurement import RangeBearing2D
from omnislam.core.motion import MotionNoise, OdometryMotionModel, compose_odometry
from omnislam.fastslam.association import NEW_LANDMARK, maximum_likelihood_association
from omnislam.fastslam.resighting import ResightingSpread


def _rotation(theta: float) -> np.ndarray:
    c, s = np.cos(theta), np.sin(theta)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


def _steps(rng: np.random.Generator, n: int) -> tuple[np.ndarray, np.ndarray]:
    """n odometry deltas of a curving path and their alpha-model covariances."""
    motion = OdometryMotionModel(MotionNoise())
    deltas = np.column_stack(
        [rng.uniform(0.05, 0.3, n), rng.normal(0.0, 0.01, n), rng.normal(0.05, 0.1, n)]
    )
    return deltas, np.array([motion.covariance(d) for d in deltas])


def test_the_running_sum_equals_composing_the_gap_step_by_step():
    """The prefix-sum form gives, for any slot, the covariance that composing the odometry of
    the steps since its sighting gives (``core.motion.compose_odometry``), turned from the frame
    of the sighting's pose into the current robot frame."""
    deltas, covs = _steps(np.random.default_rng(4), 60)
    spread = ResightingSpread()
    seen_at = {0: 0, 1: 17, 2: 41}
    headings = [0.0]
    for t, (d, c) in enumerate(zip(deltas, covs, strict=True)):
        spread.advance(d, c)
        headings.append(spread.pose[2])
        for slot, k in seen_at.items():
            if k == t + 1:
                spread.seen(np.array([slot]))
    got = spread.robot_frame(np.array([1, 2, 7]))
    for row, slot in enumerate((1, 2)):
        k = seen_at[slot]
        delta, cov = np.zeros(3), np.zeros((3, 3))
        for d, c in zip(deltas[k:], covs[k:], strict=True):
            delta, cov = compose_odometry(delta, cov, d, c)
        turn = _rotation(headings[k] - headings[-1])
        np.testing.assert_allclose(got[row], turn @ cov @ turn.T, rtol=1e-9, atol=1e-15)
    # a slot never seen has no spread
    np.testing.assert_array_equal(got[2], np.zeros((3, 3)))


def test_a_slot_seen_now_has_no_spread_and_the_scale_multiplies():
    deltas, covs = _steps(np.random.default_rng(5), 20)
    one, three = ResightingSpread(1.0), ResightingSpread(3.0)
    for spread in (one, three):
        spread.seen(np.array([0, 1]))
        for d, c in zip(deltas, covs, strict=True):
            spread.advance(d, c)
        spread.seen(np.array([1]))
    a, b = one.robot_frame(np.array([0, 1])), three.robot_frame(np.array([0, 1]))
    assert np.trace(a[0]) > 0
    np.testing.assert_allclose(b[0], 3.0 * a[0])
    np.testing.assert_array_equal(a[1], np.zeros((3, 3)))
    # the world frame of a particle turned by pi/2 rotates the position block
    world = one.world_frame(np.array([0]), np.array([one.pose[2] + np.pi / 2]))[0, 0]
    turn = _rotation(one.pose[2] + np.pi / 2)
    np.testing.assert_allclose(world, turn @ a[0] @ turn.T, atol=1e-15)


def _resighting(pose_error_rad: float):
    """One particle whose heading drifted by ``pose_error_rad`` sees a landmark 4 m ahead that
    its map holds exactly: the sighting's bearing is off by the drift."""
    model = RangeBearing2D()
    pose = np.array([[0.0, 0.0, pose_error_rad]])
    mean = np.array([[[4.0, 0.0]]])
    cov = np.array([[np.diag([1e-4, 1e-4])]])
    z = np.array([[4.0, 0.0]])
    R = np.array([np.diag([0.06**2, 0.011**2])])
    return model, pose, mean, cov, z, R


@pytest.mark.parametrize("gate", [None, chi_square_gate(0.999, 2)])
def test_the_spread_keeps_a_drifted_resighting_on_its_landmark(gate):
    """8 deg of heading drift since the sighting: without the spread the landmark is 12 sigma
    off and a new landmark starts; with a heading spread of 0.1 rad it is the same landmark."""
    model, pose, mean, cov, z, R = _resighting(np.radians(8.0))
    valid = np.ones((1, 1), dtype=bool)
    choice, _ = maximum_likelihood_association(
        pose, None, mean, cov, valid, z, R, model, -6.0, gate=gate
    )
    assert choice[0, 0] == NEW_LANDMARK
    spread = np.diag([1e-4, 1e-4, 0.1**2])[None, None]  # (P, C, 3, 3)
    choice, _ = maximum_likelihood_association(
        pose, spread, mean, cov, valid, z, R, model, -6.0, gate=gate
    )
    assert choice[0, 0] == 0


def test_the_gate_decides_by_mahalanobis_distance_alone():
    """A very wide spread lowers the best likelihood below p0 by its determinant although the
    innovation is well inside one sigma: p0 starts a new landmark, the chi-square gate keeps
    the landmark."""
    model, pose, mean, cov, z, R = _resighting(np.radians(8.0))
    valid = np.ones((1, 1), dtype=bool)
    wide = np.diag([1e4, 1e4, 1.0])[None, None]
    choice, ll = maximum_likelihood_association(pose, wide, mean, cov, valid, z, R, model, -6.0)
    assert choice[0, 0] == NEW_LANDMARK and ll[0, 0] == -6.0
    choice, ll = maximum_likelihood_association(
        pose, wide, mean, cov, valid, z, R, model, -6.0, gate=chi_square_gate(0.999, 2)
    )
    assert choice[0, 0] == 0 and ll[0, 0] == -6.0
