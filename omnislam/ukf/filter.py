"""The UKF on the robot pose (Barra & Costa sec. 4; Julier et al. 1995; Wan & van der Merwe 2000).

State x = [x, y, theta] in the map frame. filterpy's ``UnscentedKalmanFilter`` with
``MerweScaledSigmaPoints`` provides the sigma points and the filter equations; the angle-aware
parts are passed in:

* ``pose_residual`` / ``bearing_residual``: differences with the angle wrapped to [-pi, pi);
* ``pose_mean`` / ``bearing_mean``: weighted means with the angles averaged on the circle,
  atan2(sum w sin, sum w cos) (the arithmetic mean of 179 deg and -179 deg is 0, not 180).

Prediction (sec. 4, "o modelo de dinamica utiliza as observacoes dos odometros"): each sigma
point moves by the odometry through the one motion model in ``core.motion``
(``OdometryMotionModel.apply`` of the rot1-trans-rot2 decomposition), and the motion noise is
added as Q: the model's V M V^T at the mean, or, when the odometry states its covariance Sigma
(robot frame), J Sigma J^T with J = blockdiag(R(theta), 1).

Observation: the bearing of each validated line from the pose, ``core.measurement.Bearing2D``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from omnislam._optional import require
from omnislam.core.measurement import Bearing2D
from omnislam.core.motion import OdometryMotionModel
from omnislam.core.se import wrap_angle
from omnislam.ukf.config import SigmaPointsConfig

_BEARING = Bearing2D()


def pose_residual(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a - b for poses [..., 3] with the heading wrapped."""
    out = np.subtract(a, b, dtype=float)
    out[..., 2] = wrap_angle(out[..., 2])
    return out


def pose_mean(sigmas: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Weighted mean of poses (S, 3): linear in x, y; circular in theta."""
    xy = weights @ sigmas[:, :2]
    theta = math.atan2(float(weights @ np.sin(sigmas[:, 2])), float(weights @ np.cos(sigmas[:, 2])))
    return np.array([xy[0], xy[1], theta])


def bearing_residual(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a - b for bearings, wrapped."""
    return wrap_angle(np.subtract(a, b, dtype=float))


def bearing_mean(sigmas: np.ndarray, weights: np.ndarray) -> np.ndarray:
    """Circular weighted mean of each column of bearings (S, K)."""
    return np.arctan2(weights @ np.sin(sigmas), weights @ np.cos(sigmas))


def positive_definite(P: np.ndarray, floor: float = 1e-12) -> np.ndarray:
    """P symmetrised, with eigenvalues below ``floor`` raised to it when it is not positive
    definite (the unscented update P - K S K^T can lose definiteness in rounding when a bearing
    is far more certain than the pose; the next sigma points need a Cholesky factor)."""
    P = 0.5 * (P + P.T)
    try:
        np.linalg.cholesky(P)
        return P
    except np.linalg.LinAlgError:
        values, vectors = np.linalg.eigh(P)
        return (vectors * np.maximum(values, floor)) @ vectors.T


def _move(pose: np.ndarray, dt: float, components: np.ndarray) -> np.ndarray:
    del dt
    return OdometryMotionModel.apply(pose, components)


def _bearings(pose: np.ndarray, landmarks_w: np.ndarray) -> np.ndarray:
    return _BEARING.predict(pose, landmarks_w, jacobians=False)[0][:, 0]


@dataclass(frozen=True, slots=True)
class BearingPrediction:
    """The unscented prediction of the bearings of C landmarks from the current (x, P).

    The sigma points of (x, P) are moved through the bearing model: ``mean`` is their circular
    weighted mean and the (C, C) covariance of the predicted bearings is
    ``deviations.T @ diag(weights) @ deviations``, the Pzz of the filter's update without R.

    Attributes:
        mean: (C,) predicted bearings [rad].
        deviations: (S, C) sigma-point bearings minus the mean, wrapped [rad].
        weights: (S,) the covariance weights Wc.
    """

    mean: np.ndarray
    deviations: np.ndarray
    weights: np.ndarray

    @property
    def variance(self) -> np.ndarray:
        """(C,) variance of each predicted bearing [rad^2]."""
        return self.weights @ (self.deviations**2)

    def covariance(self, columns: np.ndarray) -> np.ndarray:
        """(n, n) covariance of the predicted bearings of ``columns`` [rad^2]."""
        d = self.deviations[:, columns]
        return (d * self.weights[:, None]).T @ d


class PoseUKF:
    """Mean and covariance of the pose, predicted by odometry and corrected by bearings.

    Args:
        wTr: (3,) initial pose in the map frame.
        P: (3, 3) its covariance.
        motion: the shared odometry motion model.
        sigma_points: the scaled sigma points' alpha, beta, kappa (default: SigmaPointsConfig's).
    """

    def __init__(
        self,
        wTr: np.ndarray,
        P: np.ndarray,
        motion: OdometryMotionModel,
        sigma_points: SigmaPointsConfig | None = None,
    ) -> None:
        kalman = require("filterpy.kalman")
        sp = SigmaPointsConfig() if sigma_points is None else sigma_points
        points = kalman.MerweScaledSigmaPoints(
            3, sp.alpha, sp.beta, sp.kappa, subtract=pose_residual
        )
        self._ukf = kalman.UnscentedKalmanFilter(
            dim_x=3,
            dim_z=1,
            dt=1.0,
            hx=_bearings,
            fx=_move,
            points=points,
            x_mean_fn=pose_mean,
            z_mean_fn=bearing_mean,
            residual_x=pose_residual,
            residual_z=bearing_residual,
        )
        self._ukf.x = np.asarray(wTr, dtype=float).copy()
        self._ukf.P = np.asarray(P, dtype=float).copy()
        self.motion = motion

    @property
    def x(self) -> np.ndarray:
        """(3,) the pose mean."""
        return self._ukf.x.copy()

    @property
    def P(self) -> np.ndarray:
        """(3, 3) the pose covariance."""
        return self._ukf.P.copy()

    def predict(self, delta_r: np.ndarray, covariance_r: np.ndarray | None = None) -> None:
        """Move by one odometry delta (robot frame) [dx, dy, dtheta], with its covariance if
        the data state one (else the motion model's, eq. 4.41 of the thesis's model)."""
        components = self.motion.decompose(delta_r)
        x = self._ukf.x
        if covariance_r is None:
            _, V = self.motion.apply_jacobians(x, components)
            M = np.diag(self.motion.component_sigmas(components) ** 2)
            Q = V @ M @ V.T
        else:
            c, s = math.cos(x[2]), math.sin(x[2])
            J = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
            Q = J @ np.asarray(covariance_r, dtype=float) @ J.T
        # keep Q positive definite when the robot stands still (V M V^T is then rank 1)
        self._ukf.Q = Q + np.diag([1e-12, 1e-12, 1e-12])
        self._ukf.predict(components=components)
        self._ukf.P = positive_definite(self._ukf.P)

    def innovations(
        self, bearings_rad: np.ndarray, landmarks_w: np.ndarray, sigmas_rad: np.ndarray
    ) -> np.ndarray:
        """Squared Mahalanobis distance of each bearing alone, linearised with core's Jacobian
        (for the optional innovation gate)."""
        z, H, _ = _BEARING.predict(self._ukf.x, landmarks_w)
        y = wrap_angle(np.asarray(bearings_rad) - z[:, 0])
        h = H[:, 0, :]
        s = np.einsum("ki,ij,kj->k", h, self._ukf.P, h) + np.asarray(sigmas_rad) ** 2
        return y * y / s

    def predict_bearings(self, landmarks_w: np.ndarray) -> BearingPrediction:
        """The unscented prediction of the bearings of landmarks (C, 2) [m] from (x, P): the same
        sigma points and weights as ``update``, before any measurement is chosen."""
        ukf = self._ukf
        sigmas = ukf.points_fn.sigma_points(ukf.x, ukf.P)
        landmarks = np.asarray(landmarks_w, dtype=float).reshape(-1, 2)
        z = _BEARING.predict(sigmas[:, None, :], landmarks[None], jacobians=False)[0][..., 0]
        mean = bearing_mean(z, ukf.Wm)
        return BearingPrediction(mean, wrap_angle(z - mean[None, :]), np.asarray(ukf.Wc))

    def update(
        self, bearings_rad: np.ndarray, landmarks_w: np.ndarray, sigmas_rad: np.ndarray
    ) -> None:
        """Correct with bearings (K,) of landmarks (K, 2) [m], stds (K,) [rad], all at once."""
        bearings = np.asarray(bearings_rad, dtype=float)
        if not bearings.size:
            return
        R = np.diag(np.asarray(sigmas_rad, dtype=float) ** 2)
        # the sigma points of the current (x, P): predict() left those of the prior
        self._ukf.sigmas_f = self._ukf.points_fn.sigma_points(self._ukf.x, self._ukf.P)
        self._ukf.update(bearings, R=R, landmarks_w=np.asarray(landmarks_w, dtype=float))
        self._ukf.x[2] = wrap_angle(self._ukf.x[2])
        self._ukf.P = positive_definite(self._ukf.P)
