"""A small simulated 2-D world for the EKF-SLAM tests, built from the core models only, and the
tolerances of these tests (named in one place).

A robot drives loops of a circle of radius 6 m among 12 point landmarks; odometry is corrupted
with the shared motion model (``OdometryMotionModel.sample_delta``), sightings with the Gaussian
range and bearing noise they state, inside a limited sensor range. The same noise is given to the
filter, so the filter's model is the truth's.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from omnislam.core.measurement import RangeBearing2D
from omnislam.core.motion import MotionNoise, OdometryMotionModel
from omnislam.core.se import se2_between, se2_compose, wrap_angle
from omnislam.core.types import UNKNOWN_ID, FrameInput, Odometry, RangeBearing

#: odometry noise of the simulation and of the filter
NOISE = MotionNoise(a_vv=0.05, a_vw=0.02, a_wv=0.01, a_ww=0.05)
SIGMA_RANGE_M = 0.05
SIGMA_BEARING_RAD = 0.01
MAX_RANGE_M = 6.0

#: sparse prediction/update vs the dense textbook EKF
ORACLE_ATOL = 1e-10
#: analytic vs central-difference Jacobians
JACOBIAN_ATOL = 1e-6


@dataclass(frozen=True)
class Scenario:
    """Ground truth and the frames a filter consumes (frame 0 sits at the true first pose)."""

    true_poses: np.ndarray  # (T, 3)
    landmarks_w: np.ndarray  # (M, 2)
    frames: list[FrameInput]


def circle_landmarks() -> np.ndarray:
    """12 landmarks on two rings inside and outside the circle of radius 6 m around (0, 6)."""
    inner_a = np.linspace(0, 2 * np.pi, 5, endpoint=False)
    outer_a = np.linspace(0, 2 * np.pi, 7, endpoint=False) + 0.3
    inner = 3.0 * np.stack([np.cos(inner_a), np.sin(inner_a)], axis=-1)
    outer = 9.0 * np.stack([np.cos(outer_a), np.sin(outer_a)], axis=-1)
    return np.concatenate([inner, outer]) + np.array([0.0, 6.0])


def make_scenario(
    seed: int, steps: int = 200, step_m: float = 0.3, unknown_ids: bool = False
) -> Scenario:
    """Robot starts at the origin heading +x and circles counter-clockwise around (0, 6)."""
    rng = np.random.default_rng(seed)
    motion = OdometryMotionModel(NOISE)
    sensor = RangeBearing2D()
    landmarks = circle_landmarks()
    radius = 6.0
    dtheta = step_m / radius
    chord = 2 * radius * np.sin(dtheta / 2)
    true_delta = np.array([chord * np.cos(dtheta / 2), chord * np.sin(dtheta / 2), dtheta])
    poses = [np.zeros(3)]
    frames = []
    for t in range(steps):
        if t > 0:
            poses.append(se2_compose(poses[-1], true_delta))
            measured = motion.sample_delta(true_delta, rng)
        else:
            measured = np.zeros(3)
        z, _, _ = sensor.predict(np.broadcast_to(poses[-1], (len(landmarks), 3)), landmarks)
        seen = np.flatnonzero(z[:, 0] <= MAX_RANGE_M)
        ranges = z[seen, 0] + SIGMA_RANGE_M * rng.standard_normal(seen.size)
        bearings = wrap_angle(z[seen, 1] + SIGMA_BEARING_RAD * rng.standard_normal(seen.size))
        ids = np.full(seen.size, UNKNOWN_ID) if unknown_ids else seen
        frames.append(
            FrameInput(
                index=t,
                odometry=Odometry(measured, stamp_s=0.1 * (t + 1)),
                range_bearing=RangeBearing(
                    ids, np.abs(ranges), bearings, SIGMA_RANGE_M, SIGMA_BEARING_RAD
                ),
            )
        )
    return Scenario(np.array(poses), landmarks, frames)


def pose_error(estimated: np.ndarray, true: np.ndarray) -> np.ndarray:
    """[dx, dy, dtheta] with the heading wrapped."""
    e = np.asarray(estimated, dtype=float) - np.asarray(true, dtype=float)
    e[..., 2] = wrap_angle(e[..., 2])
    return e


__all__ = ["Scenario", "make_scenario", "pose_error", "se2_between"]
