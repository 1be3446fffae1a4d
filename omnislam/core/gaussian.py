"""Multivariate Gaussians on stacks: Mahalanobis distances, log-likelihoods and draws.

The log-likelihood of an innovation y ~ N(0, S) is an estimator's measurement likelihood
(FastSLAM's importance factor, thesis eq. 4.47; association scores):

    log N(y; 0, S) = -1/2 (y^T S^-1 y + log det S + k log 2 pi).

Inverses and log-determinants come from ``omnislam.core.batch_linalg``.
"""

from __future__ import annotations

import numpy as np

from omnislam.core.batch_linalg import cholesky_jittered

#: log(2 pi), the constant of the Gaussian log-density per dimension
LOG_2PI = float(np.log(2.0 * np.pi))


def mahalanobis_squared(y: np.ndarray, S_inv: np.ndarray) -> np.ndarray:
    """y^T S^-1 y for stack-major residuals y [..., k] and inverse covariances [..., k, k]."""
    return np.einsum("...i,...ij,...j->...", y, S_inv, y)


def log_likelihood_from_mahalanobis(
    mahalanobis: np.ndarray, logdet_S: np.ndarray, dim: int
) -> np.ndarray:
    """log N(y; 0, S) = -1/2 (y^T S^-1 y + log det S + k log 2 pi) from its two terms.

    Args:
        mahalanobis: [...] squared Mahalanobis distances y^T S^-1 y.
        logdet_S: [...] log det S.
        dim: the dimension k of y.
    """
    return -0.5 * (mahalanobis + logdet_S + dim * LOG_2PI)


def gaussian_log_likelihood(y: np.ndarray, S_inv: np.ndarray, logdet_S: np.ndarray) -> np.ndarray:
    """log N(y; 0, S) for a stack of residuals y [..., k] (thesis eq. 4.47 in log space).

    Args:
        y: [..., k] residuals.
        S_inv: [..., k, k] inverse covariances.
        logdet_S: [...] log det S.
    """
    return log_likelihood_from_mahalanobis(mahalanobis_squared(y, S_inv), logdet_S, y.shape[-1])


def sample_gaussian(
    mean: np.ndarray, cov: np.ndarray, rng: np.random.Generator, jitter: float = 1e-12
) -> np.ndarray:
    """One draw from each N(mean_i, cov_i): mean + L e with cov + jitter I = L L^T, e ~ N(0, I).

    Args:
        mean: [..., k] means.
        cov: [..., k, k] symmetric positive semi-definite covariances.
        rng: the random generator (``mean.shape`` standard normal draws).
        jitter: added to the diagonal before the Cholesky factorisation.

    Returns:
        [..., k] samples.
    """
    chol = cholesky_jittered(cov, jitter)
    return mean + np.einsum("...ij,...j->...i", chol, rng.standard_normal(mean.shape))
