"""The EKF localiser and the factory omnislam's registry calls.

The state is the robot pose [x, y, theta] in the prior map's frame with its covariance. Each
frame predicts with the odometry (the linearised motion model: Thrun et al. 2005 Table 7.2,
lines 2-7) and updates with every range-bearing sighting of a mapped landmark, one at a time
(lines 8-17), after a chi-square gate on its innovation.
"""

from __future__ import annotations

from collections.abc import Mapping

import numpy as np

from ekf_localiser.config import EKFLocaliserConfig
from omnislam.core.batch_linalg import entry_major, stack_major
from omnislam.core.gating import chi_square_gate
from omnislam.core.kalman import kalman_update
from omnislam.core.measurement import RangeBearing2D
from omnislam.core.motion import MotionModel, OdometryMotionModel, StatedOdometryMotion
from omnislam.core.se import wrap_angle
from omnislam.core.sequence_info import SequenceInfo
from omnislam.core.types import Estimate, FrameInput, Odometry, PriorMap, RangeBearing, Trajectory
from omnislam.errors import ConfigError
from omnislam.options import apply_options

#: the measurement model: z = (range, bearing) of a 2-D point (core.measurement)
_RANGE_BEARING = RangeBearing2D()


class EKFLocaliser:
    """Pose EKF in a known map of point landmarks, fed range-bearing sightings with ids.

    Args:
        prior_map: the landmarks, ids matching the sightings'; its ``initial_pose_w`` is the
            start pose.
        config: noise, initial uncertainty and gate.
    """

    name = "ekf-localiser"

    def __init__(self, prior_map: PriorMap, config: EKFLocaliserConfig) -> None:
        if prior_map.initial_pose_w is None:
            raise ConfigError("ekf-localiser: the prior map states no initial pose")
        self._landmarks_w = {
            int(i): p[:2] for i, p in zip(prior_map.landmark_ids, prior_map.points_w, strict=True)
        }
        self._motion = OdometryMotionModel(config.motion_noise)
        self._gate = chi_square_gate(config.gate_probability, _RANGE_BEARING.dim_z)
        self._x = np.array(prior_map.initial_pose_w, dtype=float)
        sigmas = (config.initial_sigma_xy_m,) * 2 + (config.initial_sigma_theta_rad,)
        self._P = np.diag(np.square(sigmas))
        self._stamps_s: list[float] = []
        self._poses: list[np.ndarray] = []
        self._covariances: list[np.ndarray] = []
        self.rejected = 0

    def step(self, frame: FrameInput) -> None:
        """Predict with the frame's odometry, update with its sightings of mapped landmarks."""
        if self._poses:  # the first frame is the start pose
            self._predict(frame.odometry)
        if frame.range_bearing is not None:
            self._update(frame.range_bearing)
        self._stamps_s.append(frame.stamp_s)
        self._poses.append(self._x.copy())
        self._covariances.append(self._P.copy())

    def estimate(self) -> Estimate:
        """The filtered poses with their covariances; no landmarks (the map is given)."""
        return Estimate(
            trajectory=Trajectory.from_se2(np.array(self._stamps_s), np.array(self._poses)),
            pose_covariances=np.array(self._covariances),
        )

    def _predict(self, odometry: Odometry) -> None:
        """x' = x (+) u, P' = G P G^T + V M V^T (the odometry's stated covariance if any)."""
        motion: MotionModel = (
            self._motion
            if odometry.covariance is None
            else StatedOdometryMotion(odometry.delta, odometry.covariance)
        )
        self._x, self._P = motion.predict(self._x, self._P, odometry.delta)

    def _update(self, sightings: RangeBearing) -> None:
        """One Kalman update per gated sighting of a landmark of the map."""
        for k, landmark_id in enumerate(sightings.landmark_ids):
            point_w = self._landmarks_w.get(int(landmark_id))
            if point_w is None:
                continue
            z = np.array([sightings.ranges_m[k], sightings.bearings_rad[k]])
            R = np.diag([sightings.sigma_range_m[k] ** 2, sightings.sigma_bearing_rad[k] ** 2])
            z_hat, H, _ = _RANGE_BEARING.predict(self._x, point_w)
            y = _RANGE_BEARING.residual(z, z_hat)
            step = kalman_update(
                entry_major(self._P[None]),
                entry_major(np.ascontiguousarray(H)[None]),
                entry_major(R[None]),
                entry_major(y[None, :, None]),
                joseph=True,
            )
            if step.mahalanobis[0] > self._gate:
                self.rejected += 1
                continue
            self._x = self._x + stack_major(step.mean_step)[0, :, 0]
            self._x[2] = wrap_angle(self._x[2])
            self._P = stack_major(step.cov)[0]


def make_estimator(
    info: SequenceInfo, options: Mapping[str, str], rng: np.random.Generator
) -> EKFLocaliser:
    """Factory for omnislam's registry: the localiser in the sequence's prior map.

    Raises:
        ConfigError: no prior map (the message says how to give one), an unknown option.
    """
    del rng  # deterministic
    if info.prior_map is None:
        raise ConfigError(
            f"ekf-localiser localises in a known map and {info.name} has none; give one with "
            "--set prior_map=RUN_DIR"
        )
    return EKFLocaliser(info.prior_map, apply_options(EKFLocaliserConfig(), options))


def check_options(options: Mapping[str, str]) -> None:
    """Validate ``--set`` options against ``EKFLocaliserConfig`` without building the filter."""
    apply_options(EKFLocaliserConfig(), options)
