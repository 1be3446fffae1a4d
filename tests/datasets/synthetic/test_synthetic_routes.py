"""Differential-drive routes: limits, goal, odometry consistency, noise determinism."""

from __future__ import annotations

import numpy as np

from omnislam.core.motion import MotionNoise
from omnislam.core.se import se2_compose
from omnislam.datasets.synthetic.routes import DriveLimits, drive_through, measured_odometry

WAYPOINTS = np.array([[0.0, 0.0], [4.0, 0.0], [4.0, 3.0], [0.0, 3.0], [0.0, 0.0]])


def test_route_respects_limits_and_reaches_the_goal():
    limits = DriveLimits(max_speed_mps=0.3, max_turn_rate_radps=0.5)
    path = drive_through(WAYPOINTS, limits)
    dt = 1.0 / limits.rate_hz
    speed = np.linalg.norm(np.diff(path.poses_w[:, :2], axis=0), axis=1) / dt
    turn = np.abs(np.diff(np.unwrap(path.poses_w[:, 2]))) / dt
    assert speed.max() <= limits.max_speed_mps + 1e-9
    assert turn.max() <= limits.max_turn_rate_radps + 1e-9
    assert np.linalg.norm(path.poses_w[-1, :2] - WAYPOINTS[-1]) < 0.1
    assert 13.0 < path.length_m < 14.5


def test_true_odometry_recomposes_the_path():
    path = drive_through(WAYPOINTS, DriveLimits())
    odo = path.odometry_true()
    pose = path.poses_w[0]
    for delta in odo[1:]:
        pose = se2_compose(pose, delta)
    np.testing.assert_allclose(pose, path.poses_w[-1], atol=1e-9)


def test_measured_odometry_is_noisy_and_reproducible():
    odo = drive_through(WAYPOINTS, DriveLimits()).odometry_true()
    a = measured_odometry(odo, MotionNoise(), np.random.default_rng(1))
    b = measured_odometry(odo, MotionNoise(), np.random.default_rng(1))
    np.testing.assert_array_equal(a, b)
    assert np.all(a[0] == 0)
    assert 0 < np.abs(a[1:] - odo[1:]).mean() < 0.01


def test_the_path_followers_point_is_the_polylines_bit_for_bit():
    """The scalar look-ahead point (``_polyline_point``) is the vectorised one's, to the bit."""
    from omnislam.datasets.synthetic.routes import _polyline_point, _polyline_points

    cumlen = np.concatenate([[0.0], np.cumsum(np.linalg.norm(np.diff(WAYPOINTS, axis=0), axis=1))])
    s = np.random.default_rng(3).uniform(-1.0, cumlen[-1] + 1.0, 500)
    s[:4] = [0.0, cumlen[1], cumlen[-1], cumlen[2] + 1e-12]
    expected = _polyline_points(WAYPOINTS, cumlen, s)
    points = [tuple(map(float, p)) for p in WAYPOINTS]
    got = np.array([_polyline_point(points, cumlen.tolist(), float(v)) for v in s])
    assert np.array_equal(got, expected)
