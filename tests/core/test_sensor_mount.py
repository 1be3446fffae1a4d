"""A sensor mounted off the robot's origin: sightings and increments moved between the frames."""

import numpy as np
from tolerances import JACOBIAN_RTOL

from omnislam.core.jacobian import numerical_jacobian
from omnislam.core.se import se2_between, se2_compose, se2_inverse, se2_transform_points
from omnislam.core.sensor_mount import (
    is_at_origin,
    mounted_increments,
    range_bearing_in_robot_frame,
)

#: a SICK ahead of a Pioneer's axle, a little to the left and turned
rTs = np.array([0.25, 0.05, 0.1])
#: float round-off of a few compositions [m or rad]
ROUND_OFF = 1e-12


def _increments(rng, n):
    return np.column_stack([rng.uniform(-0.5, 0.5, (n, 2)), rng.uniform(-0.4, 0.4, n)])


def test_a_sensor_at_the_origin_changes_nothing_not_even_a_bit(rng):
    ranges, bearings = rng.uniform(0, 5, 7), rng.uniform(-3, 3, 7)
    deltas, covariances = _increments(rng, 7), np.full((7, 3, 3), np.nan)
    for origin in (None, np.zeros(3), [0.0, -0.0, 0.0]):
        assert is_at_origin(origin)
        moved = range_bearing_in_robot_frame(ranges, bearings, origin)
        assert moved[0] is ranges and moved[1] is bearings
    moved = mounted_increments(deltas, covariances, np.zeros(3))
    assert moved[0] is deltas and moved[1] is covariances
    assert not is_at_origin([0.0, 0.0, 1e-9])


def test_sightings_of_the_sensor_are_the_points_seen_from_the_robot(rng):
    points_r = rng.uniform(-6, 6, (50, 2))
    points_s = se2_transform_points(se2_inverse(rTs), points_r)
    ranges, bearings = range_bearing_in_robot_frame(
        np.hypot(points_s[:, 0], points_s[:, 1]), np.arctan2(points_s[:, 1], points_s[:, 0]), rTs)
    np.testing.assert_allclose(ranges, np.hypot(points_r[:, 0], points_r[:, 1]), atol=ROUND_OFF)
    np.testing.assert_allclose(bearings, np.arctan2(points_r[:, 1], points_r[:, 0]),
                               atol=ROUND_OFF)


def test_the_increments_of_the_sensor_are_those_of_its_poses_and_come_back(rng):
    steps = _increments(rng, 40)
    wTr = np.cumsum(steps, axis=0)  # any chain of poses
    robot = np.zeros((40, 3))
    robot[1:] = se2_between(wTr[:-1], wTr[1:])
    wTs = se2_compose(wTr, rTs)
    sensor = np.zeros((40, 3))
    sensor[1:] = se2_between(wTs[:-1], wTs[1:])
    moved, _ = mounted_increments(robot, None, rTs)
    np.testing.assert_allclose(moved, sensor, atol=ROUND_OFF)
    back, _ = mounted_increments(moved, None, se2_inverse(rTs))
    np.testing.assert_allclose(back, robot, atol=ROUND_OFF)
    assert np.abs(moved - robot).max() > 0.01  # the mount does move them


def test_covariances_follow_the_numerical_jacobian_of_the_conjugation(rng):
    deltas = _increments(rng, 5)
    L = rng.normal(size=(5, 3, 3))
    covariances = L @ np.swapaxes(L, 1, 2)
    covariances[2] = np.nan  # a kept wheel increment without a stated covariance
    _, moved = mounted_increments(deltas, covariances, rTs)
    for k in (0, 1, 3, 4):
        J = numerical_jacobian(lambda d: mounted_increments(d[None], None, rTs)[0][0],
                               deltas[k])
        expected = J @ covariances[k] @ J.T
        assert np.linalg.norm(moved[k] - expected) <= JACOBIAN_RTOL * np.linalg.norm(expected)
    assert np.isnan(moved[2]).all()
