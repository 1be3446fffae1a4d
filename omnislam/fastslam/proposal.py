"""The FastSLAM 2.0 proposal: the motion prediction refined by the matched observations.

Thesis eqs. 4.45-4.46 after Montemerlo et al. (2003); the thesis's mean update (4.46) is garbled
(SEEDS.md errata), so the update is Montemerlo's, per observation and relinearised after each:

    Q     = H_m Sigma_m H_m^T + R                         (landmark + sensor uncertainty)
    Sigma = [H_x^T Q^-1 H_x + P^-1]^-1                     (thesis 4.45)
    mu    = Sigma H_x^T Q^-1 (z - h(mu_prev, mu_m)) + mu_prev

It is evaluated in the equivalent Kalman form, which needs no inverse of the motion covariance
P (singular when the robot turns on the spot):

    L     = H_x P H_x^T + Q,   K = P H_x^T L^-1,   mu = mu_prev + K y,   Sigma = P - K L K^T,

with Sigma computed in Joseph form, (I - K H_x) P (I - K H_x)^T + K Q K^T, which stays positive
semi-definite under rounding when hundreds of bearings refine one proposal (omni camera).

The importance factor of an observation is the likelihood of z under the *predictive*
distribution, N(z; h(mu_prev, mu_m), L) = N(z; z_hat, H_x P H_x^T + H_m Sigma_m H_m^T + R)
(Montemerlo 2003, FastSLAM 2.0 importance weight; Thrun et al. 2005 sec. 13.5.3). Evaluated
sequentially -- each observation with the proposal refined by the previous ones -- the product
of the factors is the joint predictive likelihood of all observations (chain rule), exact for a
linear model.

An optional validation gate (``gate``) makes the proposal robust to outlier observations (a
feature track that jumped to another point): an observation whose innovation lies outside the
gate, y^T L^-1 y > gate, leaves the proposal unchanged and its importance factor is the
Gaussian truncated at the gate, N evaluated at Mahalanobis distance sqrt(gate).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from omnislam.core.motion import OdometryMotionModel
from omnislam.core.se import wrap_angle
from omnislam.fastslam.landmark_ekf import (
    LOG_2PI,
    MeasurementModel,
    entry_major,
    inverse_entry_major,
    product,
    quadratic_form,
    stack_major,
    symmetrised,
    transpose,
    transposed,
)

#: added to the proposal covariance's diagonal before the Cholesky factorisation
_JITTER = 1e-12


def motion_prediction(
    motion: OdometryMotionModel, wTr: np.ndarray, delta_r: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Gaussian approximation of the motion model per particle (thesis 4.41, 4.44 linearised).

    Args:
        motion: the shared odometry motion model.
        wTr: (P, 3) previous poses.
        delta_r: (3,) measured odometry delta in the robot frame.

    Returns:
        mean (P, 3) = g(x, u) and covariance (P, 3, 3) = V M V^T.
    """
    components = motion.decompose(delta_r)
    _, V = motion.apply_jacobians(wTr, components)
    M = np.diag(motion.component_sigmas(components) ** 2)
    return motion.apply(wTr, components), V @ M @ transpose(V)


@dataclass(frozen=True, slots=True)
class ProposalUpdate:
    """The proposal after one more observation, for N particles.

    Attributes:
        mean: (N, 3) refined pose mean.
        cov: (N, 3, 3) refined pose covariance.
        log_likelihood: (N,) log N(z; z_hat, L), the observation's importance factor
            (truncated at the gate for rejected observations).
        accepted: (N,) False where the observation fell outside the gate and was not used.
    """

    mean: np.ndarray
    cov: np.ndarray
    log_likelihood: np.ndarray
    accepted: np.ndarray


def refine_proposal(
    pose_mean: np.ndarray,
    pose_cov: np.ndarray,
    z: np.ndarray,
    R: np.ndarray,
    landmark_mean: np.ndarray,
    landmark_cov: np.ndarray,
    model: MeasurementModel,
    gate: float = math.inf,
) -> ProposalUpdate:
    """Incorporate one observation of an established landmark into each particle's proposal.

    Args:
        pose_mean: (N, 3) proposal means so far.
        pose_cov: (N, 3, 3) proposal covariances so far.
        z: (N, k) the observations.
        R: (N, k, k) their noise covariances.
        landmark_mean: (N, d) the observed landmarks' means.
        landmark_cov: (N, d, d) their covariances.
        model: measurement model with pose and landmark Jacobians.
        gate: validation gate on y^T L^-1 y (``association.chi_square_gate``); infinite: every
            observation is used.
    """
    z_hat, H_x, H_m = model.predict(pose_mean, landmark_mean)
    y = entry_major(model.residual(z, z_hat)[..., None])
    H_x, H_m, P = entry_major(H_x), entry_major(H_m), entry_major(pose_cov)
    Q = product(product(H_m, entry_major(landmark_cov)), transposed(H_m)) + entry_major(R)
    PHT = product(P, transposed(H_x))
    L = product(H_x, PHT) + Q
    L_inv, logdet = inverse_entry_major(L)
    K = product(PHT, L_inv)
    mean = pose_mean + stack_major(product(K, y))[..., 0]
    mean[..., 2] = wrap_angle(mean[..., 2])
    # Joseph form (I - K H_x) P (I - K H_x)^T + K Q K^T: equal to P - K L K^T for this K, but a
    # sum of PSD terms, so the covariance stays PSD after hundreds of sequential observations
    I_KH = np.eye(P.shape[0]).reshape(P.shape[0], P.shape[0], *([1] * (P.ndim - 2)))
    I_KH = I_KH - product(K, H_x)
    cov = product(product(I_KH, P), transposed(I_KH)) + product(product(K, Q), transposed(K))
    cov = stack_major(symmetrised(cov))
    mahalanobis = quadratic_form(y, L_inv)
    accepted = mahalanobis <= gate
    if not accepted.all():
        mean = np.where(accepted[:, None], mean, pose_mean)
        cov = np.where(accepted[:, None, None], cov, pose_cov)
        mahalanobis = np.minimum(mahalanobis, gate)
    log_likelihood = -0.5 * (mahalanobis + logdet + y.shape[0] * LOG_2PI)
    return ProposalUpdate(mean, cov, log_likelihood, accepted)


def sample_poses(mean: np.ndarray, cov: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Draw one pose per particle from N(mean, cov) (heading wrapped).

    Args:
        mean: (N, 3); cov: (N, 3, 3) symmetric positive semi-definite.
    """
    chol = np.linalg.cholesky(cov + _JITTER * np.eye(3))
    poses = mean + np.einsum("...ij,...j->...i", chol, rng.standard_normal(mean.shape))
    poses[..., 2] = wrap_angle(poses[..., 2])
    return poses
