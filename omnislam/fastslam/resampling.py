"""Particle weights and resampling as pure functions (filterpy style).

Weights are kept as logarithms so that products of many Gaussian likelihoods (thesis eq. 4.47)
do not underflow; normalisation (eq. 4.48) is a log-sum-exp. Resampling returns the ancestor
index of every new particle and leaves copying to the caller.
"""

from __future__ import annotations

from collections.abc import Callable
from itertools import pairwise

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
    # a draw u just below 1 rounds the last pointer (u + P - 1) / P to 1.0 itself, which
    # side="right" places past the last particle
    index = np.searchsorted(cumulative, positions, side="right")
    return np.minimum(index, len(weights) - 1).astype(np.int64)


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


def island_bounds(n_particles: int, n_islands: int) -> np.ndarray:
    """(K + 1,) start indices of K contiguous islands of near-equal size (the first
    ``P mod K`` one larger), and P at the end."""
    sizes = np.full(n_islands, n_particles // n_islands, dtype=np.int64)
    sizes[: n_particles % n_islands] += 1
    return np.concatenate([[0], np.cumsum(sizes)])


def normalize_per_island(log_weights: np.ndarray, bounds: np.ndarray) -> np.ndarray:
    """(P,) log weights normalised within each island to a total of 1/K (K = len(bounds) - 1):
    K independent particle filters whose estimates are averaged with equal weights."""
    out = np.empty_like(np.asarray(log_weights, dtype=float))
    k = len(bounds) - 1
    for a, b in pairwise(bounds):
        out[a:b] = normalize_log_weights(log_weights[a:b]) - np.log(k)
    return out


def island_resample(
    log_weights: np.ndarray,
    bounds: np.ndarray,
    ess_fraction: float,
    resampler: Callable[[np.ndarray, np.random.Generator], np.ndarray],
    rng: np.random.Generator,
) -> np.ndarray | None:
    """Resample each island from its own weights when its own ESS (thesis eq. 4.51 within the
    island) is below ``ess_fraction`` of its size (>= 1: always): independent filters.

    Args:
        log_weights: (P,) log weights, each island's summing to 1/K (``normalize_per_island``).
        bounds: (K + 1,) island start indices (``island_bounds``).
        ess_fraction: the resampling threshold as a fraction of the island's size.
        resampler: one of this module's resampling functions.
        rng: random generator.

    Returns:
        (P,) ancestors (inside each island; identity where an island was not resampled), or
        None when none was.
    """
    ancestors = np.arange(len(log_weights), dtype=np.int64)
    resampled = False
    for a, b in pairwise(bounds):
        w = np.exp(normalize_log_weights(log_weights[a:b]))
        if ess_fraction >= 1.0 or 1.0 / np.sum(w * w) < ess_fraction * (b - a):
            ancestors[a:b] = a + resampler(w, rng)
            resampled = True
    return ancestors if resampled else None
