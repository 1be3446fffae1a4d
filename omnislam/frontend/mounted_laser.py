"""The laser front end for a scanner mounted off the robot's origin (``LaserScans.offset_r``).

Scan matching and landmark extraction work in the scanner's frame s, the estimators in the
robot frame r; these functions move between them once, with ``rTs`` = ``offset_r``
(``omnislam.core.sensor_mount``; nothing moves when it is zero):

* ``robot_laser_odometry``: the scans register the scanner's motion, so the wheel odometry
  (the initial guess and the fallback) goes in as the scanner's increments
  d_s = rTs^-1 (+) d_r (+) rTs and the registered increments come back as the robot's,
  d_r = rTs (+) d_s (+) rTs^-1, covariances through the Jacobians of both conjugations; where
  no match was taken the wheel odometry is kept exactly as given.
* ``robot_laser_landmarks``: the landmarks of one scan, extracted in the scanner frame (the
  feet of the perpendicular dropped through the scanner's pose wTr (+) rTs), moved to range
  and bearing from the robot's origin. Their sigmas stay the scanner's (a ``RangeBearing``
  holds no range-bearing correlation; the change is of the order of offset / range).
"""

from __future__ import annotations

from dataclasses import replace
from typing import TYPE_CHECKING

import numpy as np

from omnislam.core.se import se2_inverse
from omnislam.core.sensor_mount import (
    is_at_origin,
    mounted_increments,
    range_bearing_in_robot_frame,
)
from omnislam.core.types import RangeBearing
from omnislam.frontend.config import LaserLandmarkConfig, LaserOdometryConfig
from omnislam.frontend.laser_landmarks import extract_laser_landmarks
from omnislam.frontend.scan_matching import LaserOdometry, laser_odometry

if TYPE_CHECKING:
    from omnislam.datasets.sequence import LaserScans


def robot_laser_odometry(
    scans: LaserScans,
    odometry_r: np.ndarray,
    config: LaserOdometryConfig,
    odometry_covariance_r: np.ndarray | None = None,
) -> LaserOdometry:
    """``scan_matching.laser_odometry`` of ``scans``, as increments of the robot.

    Args:
        scans: the scans, their scanner at ``scans.offset_r`` on the robot.
        odometry_r: (N, 3) wheel odometry of the robot (row i: frame i-1 -> i).
        config: the scan matching's thresholds.
        odometry_covariance_r: (N, 3, 3) the wheel odometry's stated covariance, or None.

    Returns:
        The LaserOdometry with the robot's increments and covariances: the registered ones
        moved from the scanner (module docstring), ``odometry_r`` and its covariance as given
        (NaN without one) wherever no match was taken.
    """
    rTs = scans.offset_r
    odometry_s, covariance_s = mounted_increments(odometry_r, odometry_covariance_r, rTs)
    found = laser_odometry(scans.angles_rad, scans.ranges_m, scans.max_range_m, odometry_s,
                           config, covariance_s)
    if is_at_origin(rTs):
        return found
    deltas, covariances = mounted_increments(found.deltas, found.covariances, se2_inverse(rTs))
    wheel = ~found.accepted
    deltas[wheel] = odometry_r[wheel]
    covariances[wheel] = np.nan if odometry_covariance_r is None else odometry_covariance_r[wheel]
    return replace(found, deltas=deltas, covariances=covariances)


def robot_laser_landmarks(
    scans: LaserScans,
    index: int,
    config: LaserLandmarkConfig,
    rng: np.random.Generator,
    pose_dr: np.ndarray | None = None,
) -> RangeBearing:
    """``laser_landmarks.extract_laser_landmarks`` of scan ``index``, from the robot's origin.

    Args:
        scans: the scans, their scanner at ``scans.offset_r`` on the robot.
        index: the frame of the scan.
        config: the extraction's thresholds.
        rng: random generator for RANSAC.
        pose_dr: (3,) the robot's dead-reckoning pose [x, y, theta] (the feet of the
            perpendicular are dropped through the scanner's pose, ``pose_dr`` (+) offset), or
            None (from the scanner itself).

    Returns:
        The sightings (ids unknown) in range and bearing from the robot's origin, in the
        robot frame.
    """
    pose_s = None if pose_dr is None else scans.scanner_poses_w(pose_dr)
    seen = extract_laser_landmarks(scans.angles_rad, scans.ranges_m[index], scans.max_range_m,
                                   config, rng, pose_s)
    if is_at_origin(scans.offset_r):
        return seen
    ranges_m, bearings_rad = range_bearing_in_robot_frame(seen.ranges_m, seen.bearings_rad,
                                                          scans.offset_r)
    return replace(seen, ranges_m=ranges_m, bearings_rad=bearings_rad)
