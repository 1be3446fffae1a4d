"""Noise models, keys and factor construction for the GTSAM back end.

All factors are GTSAM built-ins (docs/design.md: a Python ``CustomFactor`` was 3x slower per
update):

* odometry: ``BetweenFactorPose2`` / ``BetweenFactorPose3``; the 3x3 robot-frame covariance of
  the delta [dx, dy, dtheta] (``OdometryMotionModel.covariance``) is lifted into Pose3's tangent
  ordering [rx, ry, rz, tx, ty, tz] with small variances for roll, pitch and z.
* the omni bearing: ``BearingFactor3D(pose, point, Unit3)``. The factor has no body_P_sensor, so
  the Pose3 variable *is the sensor viewpoint* ``wTs = wTr * rTs`` with ``rTs`` a pure vertical
  offset (0, 0, h). For planar motion the odometry between two viewpoints equals the odometry
  between the robot frames (``rTs^-1 rTr' rTs = rTr'`` because a yaw rotation leaves the z axis
  fixed), so the same between-factor serves both; the per-pose prior holds z at h.
* per-pose planar prior: ``PriorFactorPose3`` with zero precision on x, y and yaw (no
  information), and ``planar_sigma_*`` on roll, pitch and z. Its mean is the pose's initial
  guess; the error is expressed in that guess's tangent space, which for the weighted
  components (roll, pitch, z) is insensitive to the guess's x, y and yaw unless the yaw later
  moves by nearly pi.
* 2-D: ``BearingRangeFactor2D`` and ``BearingFactor2D`` with the sighting's own sigmas.

Landmark factors may be wrapped in a Huber or Cauchy kernel (``robust``); odometry and priors
never are.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from omnislam._optional import require
from omnislam.graphslam.config import RobustKernel

gtsam = require("gtsam")
from gtsam.symbol_shorthand import L, X  # noqa: E402  (after the lazy import that names the extra)

#: Pose3 tangent indices of GTSAM's ordering [rx, ry, rz, tx, ty, tz] that hold (x, y, yaw)
POSE3_PLANAR_INDICES = np.array([3, 4, 2])
#: Pose3 tangent indices that the planar prior holds (roll, pitch, z)
POSE3_OFF_PLANE_INDICES = np.array([0, 1, 5])


def pose_key(frame: int) -> int:
    """GTSAM key of the pose of frame ``frame`` (symbol x<frame>)."""
    return X(frame)


def landmark_key(landmark_id: int) -> int:
    """GTSAM key of landmark ``landmark_id`` (symbol l<id>)."""
    return L(landmark_id)


def pose2(wTr: np.ndarray) -> Any:
    """gtsam.Pose2 from ``[x, y, theta]`` [m, m, rad]."""
    return gtsam.Pose2(float(wTr[0]), float(wTr[1]), float(wTr[2]))


def pose3_planar(wTr: np.ndarray, z_m: float = 0.0) -> Any:
    """gtsam.Pose3 with yaw ``wTr[2]``, position (x, y, z_m), no roll or pitch."""
    return gtsam.Pose3(gtsam.Rot3.Yaw(float(wTr[2])), np.array([float(wTr[0]), float(wTr[1]), z_m]))


def planar_from_pose3(wTs: Any) -> np.ndarray:
    """[x, y, yaw] of a gtsam.Pose3 (its projection onto the ground plane)."""
    t = wTs.translation()
    return np.array([t[0], t[1], wTs.rotation().yaw()])


def planar_from_pose2(wTr: Any) -> np.ndarray:
    """[x, y, theta] of a gtsam.Pose2."""
    return np.array([wTr.x(), wTr.y(), wTr.theta()])


def lift_planar_covariance(
    cov_r: np.ndarray, sigma_off_plane_m: float, sigma_off_plane_rad: float
) -> np.ndarray:
    """Embed a (3, 3) covariance of [dx, dy, dtheta] into Pose3's (6, 6) tangent covariance.

    Args:
        cov_r: (3, 3) covariance of the robot-frame delta [m^2, m^2, rad^2].
        sigma_off_plane_m: std given to tz [m].
        sigma_off_plane_rad: std given to rx and ry [rad].

    Returns:
        (6, 6) covariance in GTSAM's Pose3 ordering [rx, ry, rz, tx, ty, tz]; the off-plane
        components are uncorrelated with the planar ones.
    """
    cov6 = np.zeros((6, 6))
    cov6[np.ix_(POSE3_PLANAR_INDICES, POSE3_PLANAR_INDICES)] = cov_r
    cov6[0, 0] = cov6[1, 1] = sigma_off_plane_rad**2
    cov6[5, 5] = sigma_off_plane_m**2
    return cov6


def planar_prior_noise(sigma_off_plane_m: float, sigma_off_plane_rad: float) -> Any:
    """Pose3 noise model holding roll, pitch and z only (zero precision on x, y and yaw)."""
    precisions = np.zeros(6)
    precisions[0] = precisions[1] = sigma_off_plane_rad**-2
    precisions[5] = sigma_off_plane_m**-2
    return gtsam.noiseModel.Diagonal.Precisions(precisions)


def robust(noise: Any, kernel: RobustKernel, threshold: float) -> Any:
    """Wrap ``noise`` in a Huber or Cauchy M-estimator with ``threshold`` (whitened units)."""
    if kernel is RobustKernel.NONE:
        return noise
    if kernel is RobustKernel.HUBER:
        estimator = gtsam.noiseModel.mEstimator.Huber.Create(threshold)
    else:
        estimator = gtsam.noiseModel.mEstimator.Cauchy.Create(threshold)
    return gtsam.noiseModel.Robust.Create(estimator, noise)


class NoiseModels:
    """Builds landmark noise models and reuses them for repeated sigmas.

    Sightings of one sensor mostly share a handful of sigmas; building a GTSAM noise model in
    Python costs a few microseconds, so models are cached by their sigmas.
    """

    def __init__(self, kernel: RobustKernel, threshold: float) -> None:
        self._kernel = kernel
        self._threshold = threshold
        self._cache: dict[tuple[float, ...], Any] = {}

    def diagonal(self, *sigmas: float) -> Any:
        """(Robust) diagonal model with the given standard deviations."""
        model = self._cache.get(sigmas)
        if model is None:
            base = gtsam.noiseModel.Diagonal.Sigmas(np.asarray(sigmas, dtype=float))
            model = robust(base, self._kernel, self._threshold)
            if len(self._cache) < 4096:
                self._cache[sigmas] = model
        return model

    def isotropic(self, dim: int, sigma: float) -> Any:
        """(Robust) isotropic model of dimension ``dim``."""
        key = (float(dim), -sigma)
        model = self._cache.get(key)
        if model is None:
            base = gtsam.noiseModel.Isotropic.Sigma(dim, sigma)
            model = robust(base, self._kernel, self._threshold)
            if len(self._cache) < 4096:
                self._cache[key] = model
        return model


def condition_odometry_covariance(cov_r: np.ndarray, min_sigma_m: float) -> np.ndarray:
    """Raise an odometry covariance so its translation given the rotation has std >= a floor.

    The conditional covariance of the translation given the heading change is the Schur
    complement ``S = C_tt - C_tr C_rr^-1 C_rt`` (t = [dx, dy], r = dtheta). Adding ``a I`` to
    ``C_tt`` adds ``a I`` to ``S``; ``a = max(0, min_sigma_m^2 - lambda_min(S))`` makes every
    direction of ``S`` at least ``min_sigma_m^2`` and leaves a covariance that already satisfies
    it untouched. Why the graph needs it: ``PoseConfig.odometry_min_sigma_m``.

    Args:
        cov_r: (3, 3) covariance of the robot-frame delta ``[dx, dy, dtheta]`` [m^2, m^2, rad^2].
        min_sigma_m: the floor [m].

    Returns:
        (3, 3) the conditioned covariance (``cov_r`` itself when nothing had to change).
    """
    schur = cov_r[:2, :2]
    if cov_r[2, 2] > 0:
        schur = schur - np.outer(cov_r[:2, 2], cov_r[2, :2]) / cov_r[2, 2]
    missing = min_sigma_m**2 - np.linalg.eigvalsh(schur)[0]
    if missing <= 0:
        return cov_r
    out = np.array(cov_r, dtype=float)
    out[0, 0] += missing
    out[1, 1] += missing
    return out


def between_covariance(delta_r: np.ndarray, cov_r: np.ndarray) -> np.ndarray:
    """Covariance of a between-factor's error from that of its delta [dx, dy, dtheta].

    GTSAM's ``BetweenFactor`` error is ``Local(z, iTj) = Log(z^-1 iTj)``, a tangent vector at
    the *end* of the measured motion: a translation error ``e_t`` expressed in the start frame
    (how ``OdometryMotionModel.covariance`` and ``core.motion.compose_odometry`` state it)
    appears rotated by ``R(dtheta)^T``, to first order, the rotation error unchanged. For one
    odometry step dtheta is small; for the composed odometry between two images it is not.

    Args:
        delta_r: (3,) the measured delta [m, m, rad].
        cov_r: (3, 3) its covariance, additive in the start frame.

    Returns:
        (3, 3) covariance of the factor's [x, y, theta] error.
    """
    c, s = np.cos(delta_r[2]), np.sin(delta_r[2])
    A = np.array([[c, s, 0.0], [-s, c, 0.0], [0.0, 0.0, 1.0]])
    cov = A @ cov_r @ A.T
    return 0.5 * (cov + cov.T)


def between_pose2(i: int, j: int, delta_r: np.ndarray, cov: np.ndarray) -> Any:
    """Odometry factor from pose i to pose j: ``iTj = delta_r`` with error covariance ``cov``
    (``between_covariance`` of the delta's)."""
    return gtsam.BetweenFactorPose2(
        pose_key(i), pose_key(j), pose2(delta_r), gtsam.noiseModel.Gaussian.Covariance(cov)
    )


def between_pose3(
    i: int, j: int, delta_r: np.ndarray, cov: np.ndarray, sigma_m: float, sigma_rad: float
) -> Any:
    """Odometry factor between two Pose3 viewpoints from a planar delta (see module doc);
    ``cov`` is the (3, 3) error covariance of the planar part (``between_covariance``)."""
    cov6 = lift_planar_covariance(cov, sigma_m, sigma_rad)
    return gtsam.BetweenFactorPose3(
        pose_key(i), pose_key(j), pose3_planar(delta_r), gtsam.noiseModel.Gaussian.Covariance(cov6)
    )


def bearing_range_2d(
    frame: int, landmark_id: int, bearing_rad: float, range_m: float, noise: Any
) -> Any:
    """``BearingRangeFactor2D``; ``noise`` orders (bearing, range) as GTSAM does."""
    return gtsam.BearingRangeFactor2D(
        pose_key(frame), landmark_key(landmark_id), gtsam.Rot2(bearing_rad), range_m, noise
    )


def bearing_2d(frame: int, landmark_id: int, bearing_rad: float, noise: Any) -> Any:
    """``BearingFactor2D`` of a vertical line at ``bearing_rad`` in the robot frame."""
    return gtsam.BearingFactor2D(
        pose_key(frame), landmark_key(landmark_id), gtsam.Rot2(bearing_rad), noise
    )


def bearing_3d(frame: int, landmark_id: int, unit_vector_s: np.ndarray, noise: Any) -> Any:
    """``BearingFactor3D`` of a unit bearing in the sensor (= robot-axes) frame."""
    return gtsam.BearingFactor3D(
        pose_key(frame), landmark_key(landmark_id), gtsam.Unit3(unit_vector_s), noise
    )
