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

LOG_2PI = float(np.log(2.0 * np.pi))


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
    return -0.5 * (mahalanobis + logdet_S + y.shape[-1] * LOG_2PI)


def entry_major(a: np.ndarray) -> np.ndarray:
    """A stack of small matrices [..., r, c] as a contiguous array (r, c, ...).

    The EKF and proposal algebra works in this layout: numpy's matmul costs ~40-100 ns per
    2x2 or 3x3 matrix of a stack, several times the arithmetic, while here a product is one
    contiguous multiply-add over the whole stack per inner index (``product``).
    """
    n = a.ndim
    return np.ascontiguousarray(a.transpose(n - 2, n - 1, *range(n - 2)))


def stack_major(a: np.ndarray) -> np.ndarray:
    """Inverse of ``entry_major``: (r, c, ...) -> contiguous [..., r, c]."""
    return np.ascontiguousarray(a.transpose(*range(2, a.ndim), 0, 1))


def product(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """a @ b for entry-major stacks (r, k, ...) and (k, c, ...); the terms are summed in
    index order, as matmul does."""
    out = a[:, 0, None] * b[None, 0]
    for k in range(1, a.shape[1]):
        out += a[:, k, None] * b[None, k]
    return out


def transposed(a: np.ndarray) -> np.ndarray:
    """A^T of an entry-major stack (a view)."""
    return a.swapaxes(0, 1)


def symmetrised(a: np.ndarray) -> np.ndarray:
    """0.5 (A + A^T) of an entry-major stack."""
    return 0.5 * (a + transposed(a))


def inverse_entry_major(S: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Inverse and log-determinant of an entry-major stack of SPD matrices (closed form for
    k <= 2, ``inverse_and_logdet`` otherwise)."""
    k = S.shape[0]
    if k == 1:
        return 1.0 / S, np.log(S[0, 0])
    if k == 2:
        a, b, c, d = S[0, 0], S[0, 1], S[1, 0], S[1, 1]
        det = a * d - b * c
        inverse = np.empty_like(S)
        inverse[0, 0], inverse[0, 1] = d / det, -b / det
        inverse[1, 0], inverse[1, 1] = -c / det, a / det
        return inverse, np.log(det)
    inverse, logdet = inverse_and_logdet(stack_major(S))
    return entry_major(inverse), logdet


def quadratic_form(y: np.ndarray, M: np.ndarray) -> np.ndarray:
    """y^T M y for an entry-major stack of columns y (k, 1, ...), e.g. the Mahalanobis term
    of eq. 4.47 with M = S^-1."""
    return product(transposed(y), product(M, y))[0, 0]


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
    H = entry_major(H)
    sigma = entry_major(cov)
    PHT = product(sigma, transposed(H))
    S = product(H, PHT) + entry_major(R)  # eq. 4.34
    S_inv, logdet = inverse_entry_major(S)
    K = product(PHT, S_inv)  # eq. 4.35
    y = entry_major(y[..., None])
    new_mean = mean + stack_major(product(K, y))[..., 0]  # eq. 4.36
    # eq. 4.37: (I - K H) Sigma = Sigma - K S K^T = Sigma - K (Sigma H^T)^T, symmetrised
    new_cov = stack_major(symmetrised(sigma - product(K, transposed(PHT))))
    mahalanobis = quadratic_form(y, S_inv)
    log_likelihood = -0.5 * (mahalanobis + logdet + y.shape[0] * LOG_2PI)
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
