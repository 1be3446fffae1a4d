"""The per-landmark EKF of FastSLAM, vectorised over (particle, landmark) pairs.

Each particle treats its sampled pose as exact, so a landmark's EKF has no process model
(thesis eq. 4.30) and its update is thesis eqs. 4.33-4.37 with the shared measurement models of
``omnislam.core.measurement``. The Gaussian log-likelihood of the innovation is the particle's
importance factor in FastSLAM 1.0 (thesis eq. 4.47).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np

_LOG_2PI = float(np.log(2.0 * np.pi))


class MeasurementModel(Protocol):
    """What FastSLAM needs from an ``omnislam.core.measurement`` model."""

    @property
    def dim_z(self) -> int: ...

    def predict(self, wTr: np.ndarray, landmarks_w: np.ndarray) -> tuple[np.ndarray, ...]: ...

    def residual(self, z_measured: np.ndarray, z_predicted: np.ndarray) -> np.ndarray: ...


def transpose(a: np.ndarray) -> np.ndarray:
    """Swap the last two axes of a stack of matrices."""
    return np.swapaxes(a, -1, -2)


def inverse_and_logdet(S: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Inverse and log-determinant of a stack of SPD matrices [..., k, k] (closed form for
    k <= 2, LAPACK otherwise)."""
    k = S.shape[-1]
    if k == 1:
        return 1.0 / S, np.log(S[..., 0, 0])
    if k == 2:
        a, b, c, d = S[..., 0, 0], S[..., 0, 1], S[..., 1, 0], S[..., 1, 1]
        det = a * d - b * c
        inv = np.empty_like(S)
        inv[..., 0, 0], inv[..., 0, 1] = d / det, -b / det
        inv[..., 1, 0], inv[..., 1, 1] = -c / det, a / det
        return inv, np.log(det)
    return np.linalg.inv(S), np.linalg.slogdet(S)[1]


def gaussian_log_likelihood(y: np.ndarray, S_inv: np.ndarray, logdet_S: np.ndarray) -> np.ndarray:
    """log N(y; 0, S) for a stack of residuals [..., k] (thesis eq. 4.47 in log space)."""
    mahalanobis = np.einsum("...i,...ij,...j->...", y, S_inv, y)
    return -0.5 * (mahalanobis + logdet_S + y.shape[-1] * _LOG_2PI)


@dataclass(frozen=True, slots=True)
class LandmarkUpdate:
    """Result of ``ekf_update`` for N pairs.

    Attributes:
        mean: (N, d) updated landmark means (eq. 4.36).
        cov: (N, d, d) updated covariances (eq. 4.37, symmetrised).
        log_likelihood: (N,) log N(z; h(x, mu), S), the importance factor (eq. 4.47).
        mahalanobis: (N,) y^T S^-1 y (normalised innovation squared).
    """

    mean: np.ndarray
    cov: np.ndarray
    log_likelihood: np.ndarray
    mahalanobis: np.ndarray


def ekf_update(
    wTr: np.ndarray,
    mean: np.ndarray,
    cov: np.ndarray,
    z: np.ndarray,
    R: np.ndarray,
    model: MeasurementModel,
) -> LandmarkUpdate:
    """EKF update of N landmarks seen from N poses, thesis eqs. 4.33-4.37.

    Args:
        wTr: (N, 3) particle poses [x, y, theta].
        mean: (N, d) landmark means in the world [m].
        cov: (N, d, d) landmark covariances.
        z: (N, k) measurements.
        R: (N, k, k) measurement noise covariances (the thesis's Q, eq. 4.23).
        model: the measurement model h with its landmark Jacobian H (eq. 4.32).

    Returns:
        the updated landmarks and the innovation likelihoods.
    """
    z_hat, _, H = model.predict(wTr, mean)
    y = model.residual(z, z_hat)  # eq. 4.33
    if H.shape[-2:] == (2, 2):
        return _ekf_update_2x2(mean, cov, H, y, R)
    PHT = cov @ transpose(H)
    S = H @ PHT + R  # eq. 4.34
    S_inv, logdet = inverse_and_logdet(S)
    K = PHT @ S_inv  # eq. 4.35
    new_mean = mean + (K @ y[..., None])[..., 0]  # eq. 4.36
    # eq. 4.37: (I - K H) Sigma = Sigma - K S K^T = Sigma - K (Sigma H^T)^T, symmetrised
    new_cov = cov - K @ transpose(PHT)
    new_cov = 0.5 * (new_cov + transpose(new_cov))
    mahalanobis = np.sum(y * (S_inv @ y[..., None])[..., 0], axis=-1)
    log_likelihood = -0.5 * (mahalanobis + logdet + y.shape[-1] * _LOG_2PI)
    return LandmarkUpdate(new_mean, new_cov, log_likelihood, mahalanobis)


def _ekf_update_2x2(
    mean: np.ndarray, cov: np.ndarray, H: np.ndarray, y: np.ndarray, R: np.ndarray
) -> LandmarkUpdate:
    """``ekf_update`` for a 2-D landmark and a 2-D measurement, eqs. 4.34-4.37 written out
    per matrix entry: numpy's matmul costs ~40 ns per 2x2 matrix of a stack, many times the
    arithmetic, so entry-wise operations on (N,) arrays are several times faster. The
    operations and their order are those of the matrix form.
    """
    s00, s01, s10, s11 = cov[:, 0, 0], cov[:, 0, 1], cov[:, 1, 0], cov[:, 1, 1]
    h00, h01, h10, h11 = H[:, 0, 0], H[:, 0, 1], H[:, 1, 0], H[:, 1, 1]
    # Sigma H^T
    p00, p01 = s00 * h00 + s01 * h01, s00 * h10 + s01 * h11
    p10, p11 = s10 * h00 + s11 * h01, s10 * h10 + s11 * h11
    # S = H Sigma H^T + R (eq. 4.34) and its inverse
    a = h00 * p00 + h01 * p10 + R[:, 0, 0]
    b = h00 * p01 + h01 * p11 + R[:, 0, 1]
    c = h10 * p00 + h11 * p10 + R[:, 1, 0]
    d = h10 * p01 + h11 * p11 + R[:, 1, 1]
    det = a * d - b * c
    i00, i01, i10, i11 = d / det, -b / det, -c / det, a / det
    # K = Sigma H^T S^-1 (eq. 4.35)
    k00, k01 = p00 * i00 + p01 * i10, p00 * i01 + p01 * i11
    k10, k11 = p10 * i00 + p11 * i10, p10 * i01 + p11 * i11
    y0, y1 = y[:, 0], y[:, 1]
    new_mean = np.empty_like(mean)
    new_mean[:, 0] = mean[:, 0] + (k00 * y0 + k01 * y1)  # eq. 4.36
    new_mean[:, 1] = mean[:, 1] + (k10 * y0 + k11 * y1)
    # eq. 4.37 as Sigma - K (Sigma H^T)^T, symmetrised
    off_diagonal = 0.5 * ((s01 - (k00 * p10 + k01 * p11)) + (s10 - (k10 * p00 + k11 * p01)))
    new_cov = np.empty_like(cov)
    new_cov[:, 0, 0] = s00 - (k00 * p00 + k01 * p01)
    new_cov[:, 1, 1] = s11 - (k10 * p10 + k11 * p11)
    new_cov[:, 0, 1] = new_cov[:, 1, 0] = off_diagonal
    mahalanobis = y0 * (i00 * y0 + i01 * y1) + y1 * (i10 * y0 + i11 * y1)
    log_likelihood = -0.5 * (mahalanobis + np.log(det) + 2 * _LOG_2PI)
    return LandmarkUpdate(new_mean, new_cov, log_likelihood, mahalanobis)


def initialize_from_inverse(
    wTr: np.ndarray,
    z: np.ndarray,
    R: np.ndarray,
    inverse_fn: Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, ...]],
) -> tuple[np.ndarray, np.ndarray]:
    """First estimate of N landmarks from a full measurement: mean = h^-1(x, z) and
    Sigma = J_z R J_z^T (thesis eqs. 4.26-4.27; Montemerlo 2003 eq. 3.3x).

    Args:
        wTr: (N, 3) poses.
        z: (N, k) measurements with k = d (range-bearing, range-azimuth-elevation).
        R: (N, k, k) measurement noise.
        inverse_fn: the model's ``inverse(wTr, z) -> (landmark, J_pose, J_z)``.

    Returns:
        means (N, d) and covariances (N, d, d).
    """
    landmark, _, J_z = inverse_fn(wTr, z)
    return landmark, J_z @ R @ transpose(J_z)
