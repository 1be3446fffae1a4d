"""Forward-filtering backward-smoothing (FFBSm) of a particle filter's recorded pose clouds.

The filter's causal read-out at step t is the weighted mean of the particle set at t, an
estimate of p(x_t | z_1:t). Its genealogy (``PathHistory.ancestry_trajectory``) is a sample of
the path posterior p(x_0:T | z_1:T), but resampling prunes the lineages, so going back in time
every path passes through the same few poses (path degeneracy). FFBSm instead reweights the
particle cloud *recorded at each step* by how well it explains the smoothed cloud of the next
step (Doucet, Godsill & Andrieu 2000, "On sequential Monte Carlo sampling methods for Bayesian
filtering", sec. IV.B, eq. 43; Hürzeler & Künsch 1998):

    w_{t|T}^i = w_t^i * sum_j w_{t+1|T}^j f(x_{t+1}^j | x_t^i) / sum_k w_t^k f(x_{t+1}^j | x_t^k),

started from w_{T|T} = w_T, where w_t are the filter's normalised weights at step t (before
any resampling of that step) and f the pose transition of step t+1. The cost is O(P^2) per
step (Klaas, Briers, de Freitas, Doucet, Maskell & Lang 2006 reduce it with N-body methods; at
P = 20-100 the direct sum is cheap). The smoothed marginal of step t keeps the diversity of the
cloud recorded at t, which a later resampling of the genealogy throws away.

The transition is the Gaussian on the robot-frame odometry delta that the filter sampled from:
x_{t+1} = x_t (+) (delta_{t+1} + e), e ~ N(0, C_{t+1}) (``core.motion.StatedOdometryMotion``,
exact for it; for the alpha model, ``OdometryMotionModel``, C is its linearised covariance
``OdometryMotionModel.covariance``, the Gaussian approximation ``gap.py`` uses too), so
log f = -1/2 r^T C^-1 r + const with r = (x_t^{-1} (+) x_{t+1}) - delta_{t+1}, heading
wrapped. The constant is the same for every pair of a step and cancels.

Approximation: in FastSLAM the state of a particle is its pose *and* its map, which was built
along its own path (Rao-Blackwellisation). The backward kernel used here is the pose-only one,
as if the filter weights w_t were those of a filter over poses: the map of particle j at t+1 is
not re-conditioned on the pose x_t^i it is paired with (a Rao-Blackwellised particle smoother
would have to, Lindsten & Schön 2013, "Backward simulation methods for Monte Carlo statistical
inference", sec. 5). The smoothed poses are therefore a read-out of the recorded clouds, not the
exact smoothing distribution of the SLAM posterior.
"""

from __future__ import annotations

import numpy as np

from omnislam.core.se import se2_between, wrap_angle


def _logsumexp(a: np.ndarray, axis: int) -> np.ndarray:
    """log sum exp(a) along ``axis`` (max-shifted; an all -inf slice gives -inf)."""
    top = np.max(a, axis=axis, keepdims=True)
    top = np.where(np.isfinite(top), top, 0.0)
    out = np.log(np.sum(np.exp(a - top), axis=axis, keepdims=True)) + top
    return np.squeeze(out, axis=axis)


def transition_log_density(
    wTa: np.ndarray, wTb: np.ndarray, delta_r: np.ndarray, covariance: np.ndarray
) -> np.ndarray:
    """(P, Q) log f(x_b^j | x_a^i) up to a constant: the Gaussian of the robot-frame delta.

    Args:
        wTa: (P, 3) poses at step t [m, m, rad].
        wTb: (Q, 3) poses at step t+1.
        delta_r: (3,) the odometry delta of step t+1 in the frame of the pose at t.
        covariance: (3, 3) its covariance (positive definite).

    Returns:
        (P, Q) -1/2 r^T C^-1 r with r = (wTa_i^-1 (+) wTb_j) - delta_r (heading wrapped).
    """
    rel = se2_between(np.asarray(wTa, float)[:, None, :], np.asarray(wTb, float)[None, :, :])
    r = rel - np.asarray(delta_r, dtype=float)
    r[..., 2] = wrap_angle(r[..., 2])
    info = np.linalg.inv(np.asarray(covariance, dtype=float))
    return -0.5 * np.einsum("...a,ab,...b->...", r, info, r)


def ffbsm_log_weights(
    poses: list[np.ndarray],
    log_weights: list[np.ndarray],
    deltas_r: np.ndarray,
    covariances: np.ndarray,
) -> list[np.ndarray]:
    """The smoothed marginal log weights log w_{t|T} of every step (Doucet et al. 2000 eq. 43).

    Args:
        poses: T arrays (P, 3): the particle poses recorded at each step (before resampling).
        log_weights: T arrays (P,): the filter's normalised log weights at each step.
        deltas_r: (T, 3) the odometry delta of each step (from step t-1 to t; row 0 unused).
        covariances: (T, 3, 3) the covariance each step's delta was sampled with (row 0 unused).

    Returns:
        T arrays (P,) of normalised smoothed log weights; the last step's are the filter's.
    """
    n = len(poses)
    if n == 0:
        return []
    smoothed: list[np.ndarray] = [np.empty(0)] * n
    smoothed[-1] = np.asarray(log_weights[-1], dtype=float)
    for t in range(n - 2, -1, -1):
        lw = np.asarray(log_weights[t], dtype=float)
        log_f = transition_log_density(poses[t], poses[t + 1], deltas_r[t + 1], covariances[t + 1])
        # predictive density of each particle of step t+1 under the filter's cloud of step t
        log_pred = _logsumexp(lw[:, None] + log_f, axis=0)
        log_ratio = smoothed[t + 1][None, :] + log_f - log_pred[None, :]
        out = lw + _logsumexp(log_ratio, axis=1)
        top = np.max(out)
        smoothed[t] = out - (top + np.log(np.sum(np.exp(out - top))))
    return smoothed
