"""Laser landmarks (SLAM for Dummies): spikes and RANSAC lines as range-bearing sightings."""

from __future__ import annotations

import numpy as np
import pytest

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
    """The defaults (docs/results/frontend.md, CARMEN): corners rather than the tutorial's feet, and
    only sightings the previous scan saw there too."""
    config = LaserLandmarkConfig()
    assert config.line_landmarks is LineLandmarks.CORNERS
    assert config.persistence_radius_m == 0.2


def _cartesian_covariances(ranges_m, bearings_rad, sigma_range_m, sigma_bearing_rad):
    """(K, 2, 2) covariance J diag(sigma_r^2, sigma_b^2) J^T of each sighting's point in the
    robot frame, J the Jacobian of (r cos b, r sin b)."""
    c, s = np.cos(bearings_rad), np.sin(bearings_rad)
    J = np.stack(
        [np.stack([c, -ranges_m * s], axis=-1), np.stack([s, ranges_m * c], axis=-1)], axis=1
    )
    D = np.zeros((len(ranges_m), 2, 2))
    D[:, 0, 0], D[:, 1, 1] = sigma_range_m**2, sigma_bearing_rad**2
    return J @ D @ np.swapaxes(J, 1, 2)


def test_the_noise_floor_adds_an_isotropic_position_covariance_at_every_range():
    """``sighting_noise``: the floor s0 adds exactly s0^2 I to the Cartesian covariance of a
    sighting, near or far; without it the noise is the tutorial's (1 % of the range, at least
    1 cm; 1 deg)."""
    from omnislam.frontend.laser_landmarks import MIN_SIGMA_RANGE_M, sighting_noise

    ranges = np.array([0.4, 1.0, 3.0, 8.0])
    bearings = np.array([-1.2, 0.0, 0.7, 2.5])
    plain = LaserLandmarkConfig(sigma_floor_m=0.0)
    sr0, sb0 = sighting_noise(ranges, plain)
    np.testing.assert_allclose(sr0, np.maximum(0.01 * ranges, MIN_SIGMA_RANGE_M))
    np.testing.assert_allclose(sb0, 0.0175)
    floored = LaserLandmarkConfig(sigma_floor_m=0.03)
    sr, sb = sighting_noise(ranges, floored)
    added = _cartesian_covariances(ranges, bearings, sr, sb) - _cartesian_covariances(
        ranges, bearings, sr0, sb0
    )
    expected = np.broadcast_to(0.03**2 * np.eye(2), added.shape)
    np.testing.assert_allclose(added, expected, atol=1e-12)
    # a near sighting's position std is the floor's, not 1 % of 0.4 m
    assert np.sqrt(sr[0] ** 2 + (ranges[0] * sb[0]) ** 2) > np.sqrt(2) * 0.03


def test_extracted_sightings_carry_the_floored_noise(rng):
    """The sightings of a scan carry ``sighting_noise`` of their ranges, the default floor
    included; a negative floor is refused."""
    from omnislam.errors import ConfigError
    from omnislam.frontend.laser_landmarks import sighting_noise

    angles, ranges = _room_scan()
    config = LaserLandmarkConfig()
    assert config.sigma_floor_m == 0.03
    sightings = extract_laser_landmarks(angles, ranges, 30.0, config, rng)
    assert len(sightings)
    sr, sb = sighting_noise(sightings.ranges_m, config)
    np.testing.assert_allclose(sightings.sigma_range_m, sr)
    np.testing.assert_allclose(sightings.sigma_bearing_rad, sb)
    with pytest.raises(ConfigError, match="sigma_floor_m"):
        LaserLandmarkConfig(sigma_floor_m=-0.01)


def _poles_in(angles, ranges, poles, radius=0.03):
    """``ranges`` with the rays that hit one of the round ``poles`` shortened to it."""
    c, s = np.cos(angles), np.sin(angles)
    for p in np.asarray(poles, dtype=float):
        b = c * p[0] + s * p[1]
        disc = b**2 - (p @ p - radius**2)
        t = b - np.sqrt(np.where(disc >= 0, disc, 0.0))
        ranges = np.where((disc >= 0) & (t > 0), np.minimum(ranges, t), ranges)
    return ranges


def test_a_cluster_of_spikes_gives_no_sighting_and_an_isolated_pole_one(rng):
    """Clutter (a chair's four legs 0.3 m apart, a railing) makes spikes closer together than
    an association can tell apart: with ``min_separation_m`` none of them is a sighting, while
    a pole standing alone still is; without it every leg is one."""
    angles = np.linspace(-np.pi, np.pi, 720, endpoint=False)  # 0.5 deg beams
    _, ranges = _room_scan(pole=(10.0, 10.0), half=(4.0, 3.0), beams=720)
    chair = [(2.0, -1.0), (2.3, -1.0), (2.0, -1.3), (2.3, -1.3)]
    pole = np.array([-1.5, 1.2])
    ranges = _poles_in(angles, ranges, [*chair, tuple(pole)])
    spikes_only = {"ransac_consensus": 10**6}  # no lines: the spikes alone
    every = LaserLandmarkConfig(**spikes_only)
    assert every.min_separation_m is None
    assert len(extract_laser_landmarks(angles, ranges, 30.0, every, rng)) == 5
    separated = LaserLandmarkConfig(min_separation_m=0.5, **spikes_only)
    sightings = extract_laser_landmarks(angles, ranges, 30.0, separated, rng)
    assert len(sightings) == 1
    seen = sightings.ranges_m[0] * np.array(
        [np.cos(sightings.bearings_rad[0]), np.sin(sightings.bearings_rad[0])]
    )
    assert np.linalg.norm(seen - pole) < 0.05


def test_with_two_persistence_scans_a_sighting_needs_both_previous_scans():
    """``persistent_sightings(..., scans=2)``: a pole is kept from its third scan on, a spike
    that lasts two scans (a door swinging, a person pausing) never."""
    from omnislam.errors import ConfigError
    from omnislam.frontend.laser_landmarks import persistent_sightings

    poses = np.array([[0.3 * k, 0.0, 0.05 * k] for k in range(5)])
    pole, brief = np.array([3.0, 1.0]), np.array([2.0, -2.0])
    sightings = {
        k: _sightings_of([pole] + ([brief] if k in (2, 3) else []), poses[k]) for k in range(5)
    }
    one = persistent_sightings(sightings, poses, radius_m=0.2)
    two = persistent_sightings(sightings, poses, radius_m=0.2, scans=2)
    assert [len(one[k]) for k in range(5)] == [0, 1, 1, 2, 1]
    assert [len(two[k]) for k in range(5)] == [0, 0, 1, 1, 1]
    with pytest.raises(ConfigError, match="persistence_scans"):
        LaserLandmarkConfig(persistence_scans=0)
    with pytest.raises(ConfigError, match="min_separation_m"):
        LaserLandmarkConfig(min_separation_m=0.0)
