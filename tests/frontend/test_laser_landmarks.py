"""Laser landmarks (SLAM for Dummies): spikes and RANSAC lines as range-bearing sightings."""

from __future__ import annotations

import numpy as np

from omnislam.core.types import UNKNOWN_ID
from omnislam.frontend.config import LaserLandmarkConfig, LineLandmarks
from omnislam.frontend.laser_landmarks import extract_laser_landmarks

#: a pole sighting lies within this of the pole's near surface [m] / bearing [rad]
RANGE_TOL_M = 0.03
BEARING_TOL_RAD = np.deg2rad(1.0)
#: the tutorial's feet of the perpendicular (the default is corners)
FEET = LaserLandmarkConfig(line_landmarks=LineLandmarks.FEET)


def _room_scan(pole=(1.5, 0.5), radius=0.05, half=(3.0, 2.0), beams=360):
    """Exact ranges from the origin in a rectangular room with one round pole."""
    angles = np.linspace(-np.pi, np.pi, beams, endpoint=False)
    c, s = np.cos(angles), np.sin(angles)
    with np.errstate(divide="ignore"):
        tx = np.where(c != 0, half[0] / np.abs(c), np.inf)
        ty = np.where(s != 0, half[1] / np.abs(s), np.inf)
    ranges = np.minimum(tx, ty)
    # ray-circle intersection
    p = np.array(pole)
    b = c * p[0] + s * p[1]
    disc = b**2 - (p @ p - radius**2)
    hit = disc >= 0
    t = b - np.sqrt(np.where(hit, disc, 0.0))
    ranges = np.where(hit & (t > 0), np.minimum(ranges, t), ranges)
    return angles, ranges


def test_a_pole_is_a_spike_and_walls_are_perpendicular_feet(rng):
    angles, ranges = _room_scan()
    ranges = ranges + rng.normal(scale=0.005, size=ranges.shape)
    sightings = extract_laser_landmarks(angles, ranges, 30.0, FEET, rng)
    assert np.all(sightings.landmark_ids == UNKNOWN_ID)
    pole_range = np.hypot(1.5, 0.5) - 0.05
    pole = (np.abs(sightings.ranges_m - pole_range) < RANGE_TOL_M) & (
        np.abs(sightings.bearings_rad - np.arctan2(0.5, 1.5)) < np.deg2rad(3.0))
    assert pole.sum() == 1
    # the four walls: feet of the perpendiculars from the sensor
    expected = [(3.0, 0.0), (2.0, np.pi / 2), (3.0, np.pi), (2.0, -np.pi / 2)]
    for r, b in expected:
        d_b = np.abs((sightings.bearings_rad - b + np.pi) % (2 * np.pi) - np.pi)
        close = (np.abs(sightings.ranges_m - r) < RANGE_TOL_M) & (d_b < BEARING_TOL_RAD)
        assert close.any(), (r, b)
    assert np.all(sightings.sigma_range_m > 0) and np.all(sightings.sigma_bearing_rad > 0)


def test_readings_beyond_the_valid_range_are_ignored(rng):
    angles, ranges = _room_scan(half=(12.0, 2.0))
    sightings = extract_laser_landmarks(angles, ranges, 30.0, LaserLandmarkConfig(), rng)
    assert np.all(sightings.ranges_m < 8.1)  # the far walls at 12 m are not lines


def test_line_feet_come_from_the_odometry_origin_when_a_pose_is_given(rng):
    angles, ranges = _room_scan()
    # robot at (1, 0) facing +y in the odometry frame: the wall x_robot = 3 is the world
    # line y_w = -3 ... its foot from the world origin is (0, -3) -> robot frame (-3, 1)
    pose = np.array([1.0, 0.0, np.pi / 2])
    sightings = extract_laser_landmarks(angles, ranges, 30.0, FEET, rng, pose)
    foot_r = np.array([3.0, 1.0])
    r, b = np.hypot(*foot_r), np.arctan2(foot_r[1], foot_r[0])
    d_b = np.abs((sightings.bearings_rad - b + np.pi) % (2 * np.pi) - np.pi)
    assert np.any((np.abs(sightings.ranges_m - r) < RANGE_TOL_M) & (d_b < BEARING_TOL_RAD))


def test_corners_are_where_two_walls_meet_and_do_not_depend_on_the_pose(rng):
    """With ``line_landmarks=corners`` the lines become the room's corners that the scan
    reaches (both walls end there), the same points whatever the odometry pose."""
    angles, ranges = _room_scan(pole=(10.0, 10.0))  # pole outside the room: walls only
    ranges = ranges + rng.normal(scale=0.005, size=ranges.shape)
    config = LaserLandmarkConfig(line_landmarks=LineLandmarks.CORNERS)
    for pose in (None, np.array([1.0, 0.0, np.pi / 2])):
        sightings = extract_laser_landmarks(angles, ranges, 30.0, config, rng, pose)
        points = np.column_stack(
            [
                sightings.ranges_m * np.cos(sightings.bearings_rad),
                sightings.ranges_m * np.sin(sightings.bearings_rad),
            ]
        )
        corners = np.array([[3.0, 2.0], [-3.0, 2.0], [-3.0, -2.0], [3.0, -2.0]])
        gaps = np.linalg.norm(points[:, None, :] - corners[None], axis=-1)
        assert len(points) >= 3 and np.all(gaps.min(axis=1) < 0.05)  # only true corners
        assert np.unique(gaps.argmin(axis=1)).size == len(points)  # each once


def _sightings_of(points_w, pose):
    """RangeBearing of world points seen from ``pose`` (ids unknown)."""
    from omnislam.core.types import RangeBearing

    points_w = np.asarray(points_w, dtype=float).reshape(-1, 2)
    d = points_w - pose[:2]
    r = np.hypot(d[:, 0], d[:, 1])
    b = np.arctan2(d[:, 1], d[:, 0]) - pose[2]
    return RangeBearing(np.full(len(r), UNKNOWN_ID), r, b, 0.01 * r, 0.0175)


def test_only_sightings_the_previous_scan_saw_there_too_are_kept():
    """A pole is kept from its second scan on; a walker (0.5 m per scan) and a sighting seen
    once are never kept; the first scan keeps nothing (``persistent_sightings``)."""
    from omnislam.frontend.laser_landmarks import persistent_sightings

    poses = np.array([[0.3 * k, 0.0, 0.05 * k] for k in range(4)])
    pole, once = np.array([3.0, 1.0]), np.array([2.0, -2.0])
    walker = [np.array([1.0 + 0.5 * k, 2.0]) for k in range(4)]
    sightings = {
        k: _sightings_of([pole, walker[k]] + ([once] if k == 2 else []), poses[k])
        for k in range(4)
    }
    kept = persistent_sightings(sightings, poses, radius_m=0.2)
    assert sorted(kept) == [0, 1, 2, 3] and len(kept[0]) == 0
    for k in (1, 2, 3):
        assert len(kept[k]) == 1
        r, b = kept[k].ranges_m[0], kept[k].bearings_rad[0]
        seen = poses[k, :2] + r * np.array([np.cos(poses[k, 2] + b), np.sin(poses[k, 2] + b)])
        np.testing.assert_allclose(seen, pole, atol=1e-9)
    # placed through a pose 0.5 m off, the pole of scan 2 no longer meets scan 1's
    shifted = poses.copy()
    shifted[2, 0] += 0.5
    assert len(persistent_sightings(sightings, shifted, radius_m=0.2)[2]) == 0


def test_the_default_laser_landmarks_are_persistent_corners_and_spikes():
    """The defaults (docs/results.md, CARMEN): corners rather than the tutorial's feet, and
    only sightings the previous scan saw there too."""
    config = LaserLandmarkConfig()
    assert config.line_landmarks is LineLandmarks.CORNERS
    assert config.persistence_radius_m == 0.2
