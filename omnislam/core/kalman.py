"""The Kalman (EKF) measurement update on stacks of small Gaussians, plain or in Joseph form.

For a prior N(mu, P), a linearised measurement y = H (x - mu) + e with e ~ N(0, R) (thesis
eqs. 4.33-4.37; Thrun, Burgard & Fox 2005 Table 3.3):

    S = H P H^T + R,   K = P H^T S^-1,   mu' = mu + K y,
    P' = P - K S K^T = P - K (P H^T)^T                        (plain form)
    P' = (I - K H) P (I - K H)^T + K R K^T                    (Joseph form)

Both forms are equal for this K; the Joseph form is a sum of positive semi-definite terms, so it
stays PSD under rounding when hundreds of precise measurements update one Gaussian (an omni
camera's bearings refining a pose). Both are symmetrised. The innovation's squared Mahalanobis
distance y^T S^-1 y and log det S give its likelihood (``core.gaussian``) and its validation
gate (``core.gating``).

``kalman_update`` is the update itself in the entry-major layout of ``core.batch_linalg``, for
any state; ``ekf_update`` applies it to point landmarks seen from known poses through a
``MeasurementModel`` (FastSLAM's per-particle landmark EKFs); ``initialize_from_inverse`` gives
a first landmark estimate from one full measurement.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from omnislam.core.batch_linalg import (
    entry_major,
    inverse_entry_major,
    product,
    quadratic_form,
    stack_major,
    symmetrised,
    transpose,
    transposed,
)
from omnislam.core.gaussian import log_likelihood_from_mahalanobis
from omnislam.core.measurement import MeasurementModel


@dataclass(frozen=True, slots=True)
class KalmanStep:
    """``kalman_update`` of N Gaussians, in the entry-major layout.

    Attributes:
        mean_step: (n, 1, N) K y, to be added to the prior means (the caller wraps angles).
        cov: (n, n, N) the posterior covariances, symmetrised.
        mahalanobis: (N,) y^T S^-1 y, the normalised innovation squared.
        logdet_S: (N,) log det S.
    """

    mean_step: np.ndarray
    cov: np.ndarray
    mahalanobis: np.ndarray
    logdet_S: np.ndarray


def kalman_update(
    P: np.ndarray, H: np.ndarray, R: np.ndarray, y: np.ndarray, *, joseph: bool = False
) -> KalmanStep:
    """The Kalman measurement update of N Gaussians at once (module docstring).

    Args:
        P: (n, n, N) prior covariances, entry-major.
        H: (k, n, N) measurement Jacobians.
        R: (k, k, N) measurement noise covariances.
        y: (k, 1, N) innovations z - h(mu), angular components wrapped.
        joseph: posterior covariance in Joseph form (else the plain form).

    Returns:
        the mean step K y, the posterior covariance and the innovation statistics.
    """
    PHT = product(P, transposed(H))
    S = product(H, PHT) + R
    S_inv, logdet = inverse_entry_major(S)
    K = product(PHT, S_inv)
    mean_step = product(K, y)
    if joseph:
        n = P.shape[0]
        I_KH = np.eye(n).reshape(n, n, *([1] * (P.ndim - 2))) - product(K, H)
        cov = product(product(I_KH, P), transposed(I_KH)) + product(product(K, R), transposed(K))
    else:
        cov = P - product(K, transposed(PHT))
    return KalmanStep(mean_step, symmetrised(cov), quadratic_form(y, S_inv), logdet)


@dataclass(frozen=True, slots=True)
class LandmarkUpdate:
    """Result of ``ekf_update`` for N (pose, landmark) pairs.

    Attributes:
        mean: (N, d) updated landmark means (thesis eq. 4.36).
        cov: (N, d, d) updated covariances (eq. 4.37, symmetrised).
        log_likelihood: (N,) log N(z; h(x, mu), S), FastSLAM 1.0's importance factor (eq. 4.47).
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
    *,
    joseph: bool = False,
) -> LandmarkUpdate:
    """EKF update of N landmarks seen from N known poses, thesis eqs. 4.33-4.37.

    A pose treated as exact (a FastSLAM particle's) leaves the landmark EKF without process
    model (thesis eq. 4.30): only the measurement update remains, with the landmark Jacobian H
    of the model (eq. 4.32).

    Args:
        wTr: (N, 3) poses [x, y, theta].
        mean: (N, d) landmark means in the world [m].
        cov: (N, d, d) landmark covariances.
        z: (N, k) measurements.
        R: (N, k, k) measurement noise covariances (the thesis's Q, eq. 4.23).
        model: the measurement model h with its landmark Jacobian.
        joseph: posterior covariance in Joseph form (``kalman_update``).

    Returns:
        the updated landmarks and the innovation statistics.
    """
    z_hat, _, H = model.predict(wTr, mean)
    y = model.residual(z, z_hat)  # eq. 4.33
    y = entry_major(y[..., None])
    # eq. 4.34 S = H Sigma H^T + R, eq. 4.35 K = Sigma H^T S^-1, eqs. 4.36-4.37
    step = kalman_update(entry_major(cov), entry_major(H), entry_major(R), y, joseph=joseph)
    new_mean = mean + stack_major(step.mean_step)[..., 0]
    log_likelihood = log_likelihood_from_mahalanobis(step.mahalanobis, step.logdet_S, y.shape[0])
    return LandmarkUpdate(new_mean, stack_major(step.cov), log_likelihood, step.mahalanobis)


def initialize_from_inverse(
    wTr: np.ndarray,
    z: np.ndarray,
    R: np.ndarray,
    inverse_fn: Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, ...]],
) -> tuple[np.ndarray, np.ndarray]:
    """First estimate of N landmarks from one full measurement each: mean = h^-1(x, z) and
    Sigma = J_z R J_z^T (thesis eqs. 4.26-4.27; Montemerlo 2003's landmark initialisation).

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
