"""A room scanned by a laser mounted off the robot's origin (tests of ``LaserScans.offset_r``).

The robot drives an S across a 10 m x 8 m room (0.2 m a frame, turning left then right by up
to 0.12 rad a frame) among five thin poles (four 1.5 m from two walls, one in the room's
upper half); the scanner sits at
``OFFSET_R`` = (0.25 m, 0.05 m, 0.1 rad) on it, as a SICK ahead of a Pioneer's axle, and its
360 beams are ray-cast against the walls and poles from the scanner's own pose
wTs = wTr (+) OFFSET_R, with seeded Gaussian range noise. The wheel odometry is the true
increments with a systematic error (5 % long, 0.01 rad a frame to the left), so laser odometry
has something to correct.
"""

from __future__ import annotations

import numpy as np
from room_log import ROOM_X, ROOM_Y, ray_cast_room

from omnislam.core.se import se2_between, se2_compose, se2_integrate
from omnislam.core.types import Trajectory
from omnislam.datasets.sequence import GroundTruth, GroundTruthKind, LaserScans, Sequence

#: the room is room_log's (x in [0, ROOM_X], y in [0, ROOM_Y] [m]), with its own poles
__all__ = ["BEAMS", "OFFSET_R", "POLES_W", "POLE_RADIUS_M", "ROOM_X", "ROOM_Y", "beam_angles",
           "mounted_room", "ray_cast", "robot_path"]
#: pole centres (x, y) [m], of radius POLE_RADIUS_M
POLES_W = np.array([[5.0, 6.0], [1.5, 1.5], [8.5, 1.5], [8.5, 6.5], [1.5, 6.5]])
POLE_RADIUS_M = 0.08
#: the scanner's pose [x, y, yaw] on the robot [m, m, rad]
OFFSET_R = np.array([0.25, 0.05, 0.1])
BEAMS = 360
MAX_RANGE_M = 15.0
SIGMA_RANGE_M = 0.005


def beam_angles() -> np.ndarray:
    """(BEAMS,) beam angles in the scanner frame, 1 deg apart from -pi."""
    return -np.pi + np.arange(BEAMS) * 2.0 * np.pi / BEAMS


def robot_path(frames: int) -> np.ndarray:
    """(frames, 3) true robot poses: the S, from (1.2, 4.0) heading -0.95 rad."""
    turn = 0.12 * np.sin(2.0 * np.pi * np.arange(frames) / frames)
    steps = np.column_stack([np.full(frames, 0.2), np.zeros(frames), turn])
    return se2_integrate(steps, np.array([1.2, 4.0, -0.95]))


def ray_cast(wTs: np.ndarray, angles_rad: np.ndarray) -> np.ndarray:
    """(B,) exact ranges [m] of beams ``angles_rad`` (scanner frame) from the scanner pose
    ``wTs`` to the nearest wall or pole."""
    return ray_cast_room(wTs[0], wTs[1], wTs[2] + angles_rad, POLES_W, POLE_RADIUS_M)


def mounted_room(frames: int = 50, seed: int = 0, declared_offset_r: np.ndarray | None = None
                 ) -> Sequence:
    """The room's sequence: scans taken from ``OFFSET_R``, declared with ``declared_offset_r``
    (default ``OFFSET_R``; zeros: the scanner wrongly taken to be at the robot's origin)."""
    rng = np.random.default_rng(seed)
    truth = robot_path(frames)
    angles = beam_angles()
    ranges = np.array([ray_cast(wTs, angles) for wTs in se2_compose(truth, OFFSET_R)])
    ranges = np.minimum(ranges + rng.normal(0.0, SIGMA_RANGE_M, ranges.shape), MAX_RANGE_M)
    true_r = np.zeros((frames, 3))
    true_r[1:] = se2_between(truth[:-1], truth[1:])
    wheel_r = true_r * np.array([1.05, 1.05, 1.0]) + np.array([0.0, 0.0, 0.01])
    wheel_r[0] = 0.0
    stamps = np.arange(frames, dtype=float)
    offset = OFFSET_R if declared_offset_r is None else declared_offset_r
    return Sequence(
        name="mounted-room",
        source="tests/mounted_laser_room.py",
        stamps_s=stamps,
        odometry_r=wheel_r,
        odometry_true_r=true_r,
        ground_truth=GroundTruth(
            GroundTruthKind.EXACT, Trajectory.from_se2(stamps, truth),
            np.arange(len(POLES_W)), np.column_stack([POLES_W, np.zeros(len(POLES_W))])),
        laser=LaserScans(angles, ranges, MAX_RANGE_M, offset_r=offset),
    )
