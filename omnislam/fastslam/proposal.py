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
semi-definite under rounding when hundreds of bearings refine one proposal (omni camera): the
shared ``core.kalman.kalman_update`` with Q as the measurement noise. The motion prediction
N(mu_prev, P) it starts from is the motion model's linearised prediction from the exactly known
previous pose of each particle (``MotionModel.predict(wTr, None, delta)``, thesis 4.41, 4.44).

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

``joint_proposal`` (``ProposalUpdateMode.JOINT``) instead incorporates all matched observations
of a particle in one Gaussian update linearised at the motion-prediction mean; its derivation is
in its docstring.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from omnislam.core.batch_linalg import (
    entry_major,
    inverse_3x3_entry_major,
    inverse_entry_major,
    product,
    quadratic_form,
    stack_major,
    symmetrised,
    transposed,
)
from omnislam.core.gaussian import LOG_2PI, log_likelihood_from_mahalanobis, sample_gaussian
from omnislam.core.kalman import kalman_update
from omnislam.core.measurement import MeasurementModel
from omnislam.core.se import wrap_angle

#: added to the proposal covariance's diagonal before the Cholesky factorisation
_JITTER = 1e-12


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
        gate: validation gate on y^T L^-1 y (``core.gating.chi_square_gate``); infinite: every
            observation is used.
    """
    z_hat, H_x, H_m = model.predict(pose_mean, landmark_mean)
    y = entry_major(model.residual(z, z_hat)[..., None])
    H_x, H_m, P = entry_major(H_x), entry_major(H_m), entry_major(pose_cov)
    Q = product(product(H_m, entry_major(landmark_cov)), transposed(H_m)) + entry_major(R)
    # L = H_x P H_x^T + Q; Joseph form (I - K H_x) P (I - K H_x)^T + K Q K^T: equal to
    # P - K L K^T for this K, but a sum of PSD terms, so the covariance stays PSD after
    # hundreds of sequential observations
    step = kalman_update(P, H_x, Q, y, joseph=True)
    mean = pose_mean + stack_major(step.mean_step)[..., 0]
    mean[..., 2] = wrap_angle(mean[..., 2])
    cov = stack_major(step.cov)
    mahalanobis, logdet = step.mahalanobis, step.logdet_S
    accepted = mahalanobis <= gate
    if not accepted.all():
        mean = np.where(accepted[:, None], mean, pose_mean)
        cov = np.where(accepted[:, None, None], cov, pose_cov)
        mahalanobis = np.minimum(mahalanobis, gate)
    log_likelihood = log_likelihood_from_mahalanobis(mahalanobis, logdet, y.shape[0])
    return ProposalUpdate(mean, cov, log_likelihood, accepted)


@dataclass(frozen=True, slots=True)
class JointProposal:
    """The proposal after all matched observations at once, for P particles.

    Attributes:
        mean: (P, 3) refined pose means (the prediction where a particle has no observation).
        cov: (P, 3, 3) refined pose covariances.
        log_likelihood: (P,) log of the joint predictive likelihood of the particle's accepted
            observations, plus the gate-truncated factor of each rejected one (0 without
            observations).
        accepted: (N,) per (particle, observation) pair: False where it fell outside the gate.
    """

    mean: np.ndarray
    cov: np.ndarray
    log_likelihood: np.ndarray
    accepted: np.ndarray


def joint_proposal(
    pose_mean: np.ndarray,
    pose_cov: np.ndarray,
    particle: np.ndarray,
    z: np.ndarray,
    R: np.ndarray,
    landmark_mean: np.ndarray,
    landmark_cov: np.ndarray,
    model: MeasurementModel,
    gate: float = math.inf,
) -> JointProposal:
    """All matched observations of each particle in one update at the motion prediction.

    For a particle with prediction N(mu0, P) and accepted observations j = 1..k, each
    linearised at (mu0, mu_mj): y_j = z_j - h(mu0, mu_mj), pose Jacobian H_j (m x 3) and
    Q_j = H_mj Sigma_mj H_mj^T + R_j (landmark + sensor, as in thesis 4.45). Stacked,
    y = H (x - mu0) + e with e ~ N(0, Q), H (km x 3) and Q = blockdiag(Q_j). The Gaussian update
    with all of them at once is thesis eq. 4.45 with stacked H and Q:

        Sigma^-1 = P^-1 + A,      A = H^T Q^-1 H   = sum_j H_j^T Q_j^-1 H_j     (3 x 3)
        mu       = mu0 + Sigma b, b = H^T Q^-1 y   = sum_j H_j^T Q_j^-1 y_j     (3)

    P is singular when the robot turns on the spot, so Sigma is evaluated without P^-1:
    (P^-1 + A)^-1 = (P^-1 (I + P A))^-1 = (I + P A)^-1 P, and by Woodbury with U = P H^T,
    V = H, (I + P H^T Q^-1 H)^-1 = I - P H^T (Q + H P H^T)^-1 H, so

        Sigma = (I + P A)^-1 P = P - P H^T (H P H^T + Q)^-1 H P,

    the Kalman form with stacked observations, valid for any PSD P; the push-through identity
    (I + P A)^-1 P H^T Q^-1 = P H^T (Q + H P H^T)^-1 makes Sigma b = K y the Kalman mean step.
    I + P A is invertible: det(I + P A) = det(I + Q^-1/2 H P H^T Q^-1/2) >= 1.

    The importance factor is the joint predictive likelihood N(y; 0, L) with
    L = H P H^T + Q (Montemerlo 2003; the product of the sequential factors for a linear
    model, by the chain rule), evaluated without forming the (km x km) L:

        log det L   = log det Q + log det(I + Q^-1 H P H^T) = sum_j log det Q_j + log det(I + P A)
                                                              (determinant lemma / Sylvester)
        y^T L^-1 y  = y^T Q^-1 y - y^T Q^-1 H (I + P A)^-1 P H^T Q^-1 y
                    = sum_j y_j^T Q_j^-1 y_j - b^T Sigma b      (Woodbury)
        log N       = -1/2 (y^T L^-1 y + log det L + k m log 2 pi).

    The validation gate keeps the sequential semantics, evaluated at the prediction: pair j is
    rejected when y_j^T L_j^-1 y_j > gate with L_j = H_j P H_j^T + Q_j; it is left out of A, b
    and the likelihood, and contributes the Gaussian truncated at the gate,
    -1/2 (gate + log det L_j + m log 2 pi).

    Vectorisation: every per-pair quantity is computed for all N pairs at once in the
    entry-major layout (``core.batch_linalg.entry_major``); the per-particle sums of A (9 entries),
    b (3) and the scalar terms are one ``np.bincount`` over the pairs; the 3 x 3 algebra is then
    one closed-form pass over the particles.

    Args:
        pose_mean: (P, 3) motion-prediction means mu0.
        pose_cov: (P, 3, 3) motion-prediction covariances P (PSD, possibly singular).
        particle: (N,) the particle of each (particle, observation) pair, any order.
        z: (N, m) the observations; R: (N, m, m) their noise covariances.
        landmark_mean: (N, d) the observed landmarks' means; landmark_cov: (N, d, d).
        model: measurement model with pose and landmark Jacobians.
        gate: validation gate on y_j^T L_j^-1 y_j; infinite: every observation is used.
    """
    n_particles = pose_mean.shape[0]
    n = particle.shape[0]
    z_hat, H_x, H_m = model.predict(pose_mean[particle], landmark_mean)
    y = entry_major(model.residual(z, z_hat)[..., None])  # (m, 1, N)
    m = y.shape[0]
    H_x, H_m = entry_major(H_x), entry_major(H_m)
    Q = product(product(H_m, entry_major(landmark_cov)), transposed(H_m)) + entry_major(R)
    Q_inv, logdet_Q = inverse_entry_major(Q)
    HtQ_inv = product(transposed(H_x), Q_inv)  # (3, m, N)
    A_j = product(HtQ_inv, H_x)  # (3, 3, N)
    b_j = product(HtQ_inv, y)  # (3, 1, N)
    scalar = quadratic_form(y, Q_inv) + logdet_Q + m * LOG_2PI
    if math.isfinite(gate):
        P_rows = entry_major(pose_cov[particle])
        L = product(H_x, product(P_rows, transposed(H_x))) + Q
        L_inv, logdet_L = inverse_entry_major(L)
        accepted = quadratic_form(y, L_inv) <= gate
        A_j = A_j * accepted
        b_j = b_j * accepted
        scalar = np.where(accepted, scalar, gate + logdet_L + m * LOG_2PI)
    else:
        accepted = np.ones(n, dtype=bool)
    # per-particle sums: rows 0-8 A (entry-major 3 x 3), 9-11 b, 12 the scalar terms
    terms = np.concatenate([A_j.reshape(9, n), b_j.reshape(3, n), scalar[None]])
    index = (np.arange(13)[:, None] * n_particles + particle[None, :]).ravel()
    sums = np.bincount(index, weights=terms.ravel(), minlength=13 * n_particles)
    sums = sums.reshape(13, n_particles)
    A = sums[:9].reshape(3, 3, n_particles)
    b = sums[9:12].reshape(3, 1, n_particles)
    P = entry_major(pose_cov)
    I_PA = np.eye(3)[:, :, None] + product(P, A)
    I_PA_inv, det_I_PA = inverse_3x3_entry_major(I_PA)
    Sigma = symmetrised(product(I_PA_inv, P))
    mean = pose_mean + stack_major(product(Sigma, b))[..., 0]
    mean[..., 2] = wrap_angle(mean[..., 2])
    log_likelihood = -0.5 * (sums[12] - quadratic_form(b, Sigma) + np.log(det_I_PA))
    return JointProposal(mean, stack_major(Sigma), log_likelihood, accepted)


def sample_poses(mean: np.ndarray, cov: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Draw one pose per particle from N(mean, cov) (heading wrapped).

    Args:
        mean: (N, 3); cov: (N, 3, 3) symmetric positive semi-definite.
    """
    poses = sample_gaussian(mean, cov, rng, _JITTER)
    poses[..., 2] = wrap_angle(poses[..., 2])
    return poses
