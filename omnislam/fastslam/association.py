"""Per-particle maximum-likelihood data association with a new-landmark threshold.

Montemerlo 2003 (FastSLAM with unknown data association) / Thrun et al. 2005 sec. 13.6: every
particle independently picks, for each sighting, the landmark of its own map that explains it
best; if even the best explains it with likelihood below p0, the particle creates a new
landmark. Different particles may associate differently; wrong hypotheses die out in
resampling.
"""

from __future__ import annotations

import numpy as np

from omnislam.core.batch_linalg import inverse_and_logdet, transpose
from omnislam.core.gaussian import gaussian_log_likelihood
from omnislam.core.measurement import MeasurementModel

#: association result meaning "a new landmark"
NEW_LANDMARK = -1


def maximum_likelihood_association(
    poses: np.ndarray,
    pose_cov: np.ndarray | None,
    landmark_mean: np.ndarray,
    landmark_cov: np.ndarray,
    landmark_valid: np.ndarray,
    z: np.ndarray,
    R: np.ndarray,
    model: MeasurementModel,
    log_p0: float,
) -> tuple[np.ndarray, np.ndarray]:
    """Associate K sightings with C candidate landmarks in each of P particles.

    The likelihood of sighting k under landmark c is N(z_k; h(x, mu_c), S) with
    S = H_m Sigma_c H_m^T + R_k, plus H_x P H_x^T when the pose is still uncertain (FastSLAM 2.0
    associates before sampling, with the motion prediction's covariance P).

    Args:
        poses: (P, 3) particle poses (sampled, or the predicted means for FastSLAM 2.0).
        pose_cov: (P, 3, 3) pose covariance, or None for a sampled (exact) pose.
        landmark_mean: (P, C, d) candidates in each particle's map.
        landmark_cov: (P, C, d, d) their covariances.
        landmark_valid: (P, C) False where the particle has no estimate of the candidate.
        z: (K, k) sightings; R: (K, k, k) their noise.
        model: measurement model.
        log_p0: log-likelihood threshold for a new landmark.

    Returns:
        choice (P, K): candidate index, or ``NEW_LANDMARK``; and log_likelihood (P, K) of the
        choice (log_p0 for new landmarks).
    """
    p, c = landmark_valid.shape
    k = z.shape[0]
    if c == 0:
        return np.full((p, k), NEW_LANDMARK), np.full((p, k), log_p0)
    z_hat, H_x, H_m = model.predict(poses[:, None, :], landmark_mean)  # (P, C, ...)
    S = H_m @ landmark_cov @ transpose(H_m)
    if pose_cov is not None:
        S = S + H_x @ pose_cov[:, None] @ transpose(H_x)
    S = S[:, None] + R[None, :, None]  # (P, K, C, k, k)
    y = model.residual(z[None, :, None, :], z_hat[:, None])
    S_inv, logdet = inverse_and_logdet(S)
    log_likelihood = gaussian_log_likelihood(y, S_inv, logdet)
    log_likelihood = np.where(landmark_valid[:, None, :], log_likelihood, -np.inf)
    best = np.argmax(log_likelihood, axis=2)
    best_ll = np.take_along_axis(log_likelihood, best[..., None], axis=2)[..., 0]
    new = best_ll < log_p0
    return np.where(new, NEW_LANDMARK, best), np.where(new, log_p0, best_ll)
