"""Particle weights and resampling as pure functions (filterpy style).

Weights are kept as logarithms so that products of many Gaussian likelihoods (thesis eq. 4.47)
do not underflow; normalisation (eq. 4.48) is a log-sum-exp. Resampling returns the ancestor
index of every new particle and leaves copying to the caller.
"""

from __future__ import annotations

import numpy as np


def normalize_log_weights(log_weights: np.ndarray) -> np.ndarray:
    """Thesis eq. 4.48 in log space: log w_i - log sum_j w_j (log-sum-exp; max weight -> finite).

    Args:
        log_weights: (P,) unnormalised log weights (-inf allowed, not all).

    Returns:
        (P,) log weights whose exponentials sum to one.
    """
    log_weights = np.asarray(log_weights, dtype=float)
    top = np.max(log_weights)
    if not np.isfinite(top):
        return np.full(log_weights.shape, -np.log(log_weights.size))
    return log_weights - (top + np.log(np.sum(np.exp(log_weights - top))))


def effective_sample_size(log_weights: np.ndarray) -> float:
    """Thesis eqs. 4.50-4.51: ESS = P / (1 + cv^2) = 1 / sum w_i^2 for normalised weights.

    (cv^2 = (1/P) sum (P w_i - 1)^2 = P sum w_i^2 - 1, so both forms agree.)
    """
    w = np.exp(normalize_log_weights(log_weights))
    return float(1.0 / np.sum(w * w))


def coefficient_of_variation(log_weights: np.ndarray) -> float:
    """Thesis eq. 4.50: cv^2 = (1/P) sum_i (P w_i - 1)^2 of the normalised weights."""
    w = np.exp(normalize_log_weights(log_weights))
    p = w.size
    return float(np.mean((p * w - 1.0) ** 2))


def _search(weights: np.ndarray, positions: np.ndarray) -> np.ndarray:
    cumulative = np.cumsum(weights)
    cumulative[-1] = 1.0  # guard against round-off below the last position
    return np.searchsorted(cumulative, positions, side="right").astype(np.int64)


def systematic_resample(weights: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Low-variance resampling (Thrun, Burgard & Fox 2005, Table 4.4): one uniform draw,
    P evenly spaced pointers. O(P); a particle with weight w gets floor(P w) or ceil(P w) copies.

    Args:
        weights: (P,) normalised weights.
        rng: random generator.

    Returns:
        (P,) ancestor indices, sorted.
    """
    p = len(weights)
    positions = (rng.random() + np.arange(p)) / p
    return _search(np.asarray(weights, dtype=float), positions)


def stratified_resample(weights: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """One uniform draw per stratum [i/P, (i+1)/P)."""
    p = len(weights)
    positions = (rng.random(p) + np.arange(p)) / p
    return _search(np.asarray(weights, dtype=float), positions)


def multinomial_resample(weights: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Roulette-wheel resampling, thesis eq. 4.49: P independent draws from the weights."""
    p = len(weights)
    return _search(np.asarray(weights, dtype=float), np.sort(rng.random(p)))
