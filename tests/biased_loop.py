"""A lap under biased odometry that closes on its first landmarks: the outlier gate's hard case.

Shared by the graph and EKF-SLAM tests of ``core.gating.GatedResightings``. The robot drives a
circle once and a quarter with a short-range sensor, so the first landmarks are seen again only
after a lap; its odometry turns a little too much every step (a systematic error like the
synthetic presets' realistic drift) while the estimators model white noise only. At the
re-sighting the pose estimate is metres off and its covariance says decimetres: the gate
rejects the sightings that close the loop.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from omnislam.core.measurement import RangeBearing2D
from omnislam.core.motion import MotionNoise, OdometryMotionModel
from omnislam.core.se import se2_between
from omnislam.core.types import FrameInput, Odometry, RangeBearing

#: the estimators' white odometry noise (thesis eq. 4.41 alphas)
LOOP_MOTION_NOISE = MotionNoise(a_vv=0.005, a_vw=0.002, a_wv=0.002, a_ww=0.005)
#: the odometry's systematic heading error per step [rad] (0.4 rad over the lap)
HEADING_BIAS_RAD = 0.003
#: the sensor's reach [m]: a landmark is seen over a sixth of the lap
MAX_RANGE_M = 4.0
SIGMA_RANGE_M, SIGMA_BEARING_RAD = 0.03, 0.01


@dataclass(frozen=True)
class BiasedLoop:
    """Frames, truth, and the frame from which the first landmarks are seen again."""

    frames: list[FrameInput]
    poses_true: np.ndarray  # (N, 3)
    landmarks_true: np.ndarray  # (M, 2)
    closing_frame: int

    def end_error_m(self, poses: np.ndarray) -> float:
        """Position error of the last pose [m] (both start at the true first pose)."""
        return float(np.hypot(*(np.asarray(poses)[-1, :2] - self.poses_true[-1, :2])))


def simulate_biased_loop(rng: np.random.Generator, n: int = 250) -> BiasedLoop:
    """1.25 laps of a circle of radius 8 m, 24 landmarks on rings 1-3 m outside and inside it."""
    angles = np.linspace(0.0, 2.5 * np.pi, n)
    poses = np.column_stack([8.0 * np.sin(angles), 8.0 * (1 - np.cos(angles)), angles])
    phi = np.linspace(0.0, 2 * np.pi, 24, endpoint=False) + 0.1
    radius = np.where(np.arange(24) % 2 == 0, 6.0, 10.0) + rng.uniform(-1.0, 1.0, 24)
    landmarks = np.column_stack([radius * np.sin(phi), 8.0 - radius * np.cos(phi)])
    model, sensor = OdometryMotionModel(LOOP_MOTION_NOISE), RangeBearing2D()
    frames, first_seen, closing = [], {}, None
    for k in range(n):
        delta = np.zeros(3)
        if k:
            delta = model.sample_delta(se2_between(poses[k - 1], poses[k]), rng)
            delta[2] += HEADING_BIAS_RAD
        z, _, _ = sensor.predict(np.broadcast_to(poses[k], (len(landmarks), 3)), landmarks)
        seen = np.flatnonzero(z[:, 0] < MAX_RANGE_M)
        for i in seen.tolist():
            if closing is None and k - first_seen.setdefault(i, k) > n // 2:
                closing = k
        frames.append(
            FrameInput(
                index=k,
                odometry=Odometry(delta, float(k)),
                range_bearing=RangeBearing(
                    seen,
                    z[seen, 0] + SIGMA_RANGE_M * rng.standard_normal(len(seen)),
                    z[seen, 1] + SIGMA_BEARING_RAD * rng.standard_normal(len(seen)),
                    SIGMA_RANGE_M,
                    SIGMA_BEARING_RAD,
                ),
            )
        )
    assert closing is not None, "the lap never re-sees a landmark"
    return BiasedLoop(frames, poses, landmarks, closing)
