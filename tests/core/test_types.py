import numpy as np
import pytest

from omnislam.core.se import se3_from_se2
from omnislam.core.types import (
    Bearings,
    Estimate,
    FrameInput,
    Odometry,
    RangeBearing,
    Trajectory,
)
from omnislam.errors import DataError


def test_records_are_read_only_copies():
    delta = np.array([0.1, 0.0, 0.05])
    odom = Odometry(delta, 1.0)
    delta[0] = 99.0
    assert odom.delta[0] == pytest.approx(0.1), "the record owns a copy"
    with pytest.raises(ValueError):
        odom.delta[0] = 1.0
    with pytest.raises(AttributeError):
        odom.stamp_s = 2.0  # type: ignore[misc]


def test_bearings_validation():
    ok = Bearings([1, 2], [[1.0, 0, 0], [0, 1.0, 0]], [0.01, 0.02])
    assert len(ok) == 2
    with pytest.raises(DataError, match="unit norm"):
        Bearings([1], [[2.0, 0, 0]], [0.01])
    with pytest.raises(DataError, match="shape"):
        Bearings([1, 2], [[1.0, 0, 0]], [0.01, 0.01])
    with pytest.raises(DataError, match="positive"):
        Bearings([1], [[1.0, 0, 0]], [0.0])


def test_range_bearing_broadcasts_scalar_sigmas_and_rejects_nan():
    rb = RangeBearing([3, -1], [1.0, 2.0], [0.1, -0.2], 0.05, np.deg2rad(1.0))
    assert rb.sigma_range_m.shape == (2,)
    with pytest.raises(DataError, match="NaN"):
        RangeBearing([3], [np.nan], [0.1], 0.05, 0.01)
    with pytest.raises(DataError, match="non-negative"):
        RangeBearing([3], [-1.0], [0.1], 0.05, 0.01)


def test_trajectory_checks_and_planar_views():
    poses = np.array([[0.0, 0, 0], [1.0, 0.5, 0.3], [2.0, 1.0, -3.0]])
    traj = Trajectory.from_se2([0.0, 0.1, 0.2], poses)
    np.testing.assert_allclose(traj.se2, poses, atol=1e-12)
    assert traj.positions_w.shape == (3, 3) and len(traj) == 3
    with pytest.raises(DataError, match="increasing"):
        Trajectory([0.0, 0.0], se3_from_se2(poses[:2]))
    bad = se3_from_se2(poses)
    bad[1, 0, 0] = 2.0
    with pytest.raises(DataError, match="orthonormal"):
        Trajectory([0.0, 0.1, 0.2], bad)


def test_estimate_requires_unique_ids_and_matching_shapes():
    traj = Trajectory.from_se2([0.0], [[0.0, 0, 0]])
    est = Estimate(traj, [4, 7], [[0.0, 1, 0], [1.0, 2, 0]])
    assert est.landmarks_w.shape == (2, 3) and est.landmark_covariances is None
    with pytest.raises(DataError, match="unique"):
        Estimate(traj, [4, 4], np.zeros((2, 3)))
    with pytest.raises(DataError, match="shape"):
        Estimate(traj, [4], np.zeros((2, 3)))


def test_frame_input_stamp_comes_from_odometry():
    frame = FrameInput(index=3, odometry=Odometry([0.1, 0, 0], 4.5))
    assert frame.stamp_s == 4.5 and frame.bearings is None
