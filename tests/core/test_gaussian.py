"""Gaussian log-likelihoods against scipy, and the sampler's moments."""

import numpy as np
import pytest
from scipy.stats import multivariate_normal
from tolerances import MOMENT_RTOL

from omnislam.core.batch_linalg import inverse_and_logdet
from omnislam.core.gaussian import (
    LOG_2PI,
    gaussian_log_likelihood,
    log_likelihood_from_mahalanobis,
    mahalanobis_squared,
    sample_gaussian,
)


@pytest.mark.parametrize("k", [1, 2, 3])
def test_log_likelihood_equals_scipys_logpdf(rng, k):
    C = rng.normal(size=(6, k, k))
    S = C @ np.swapaxes(C, 1, 2) + 0.1 * np.eye(k)
    y = rng.normal(size=(6, k))
    S_inv, logdet = inverse_and_logdet(S)
    expected = [multivariate_normal(np.zeros(k), S[i]).logpdf(y[i]) for i in range(6)]
    np.testing.assert_allclose(gaussian_log_likelihood(y, S_inv, logdet), expected, rtol=1e-12)
    m = mahalanobis_squared(y, S_inv)
    np.testing.assert_allclose(m, [y[i] @ np.linalg.solve(S[i], y[i]) for i in range(6)])
    np.testing.assert_array_equal(
        log_likelihood_from_mahalanobis(m, logdet, k), gaussian_log_likelihood(y, S_inv, logdet)
    )
    assert LOG_2PI == np.log(2 * np.pi)


def test_samples_have_the_requested_moments(rng):
    mean = np.array([1.0, -1.0, 0.5])
    cov = np.array([[0.04, 0.01, 0.0], [0.01, 0.09, 0.002], [0.0, 0.002, 0.01]])
    n = 200_000
    samples = sample_gaussian(np.tile(mean, (n, 1)), np.tile(cov, (n, 1, 1)), rng)
    assert np.linalg.norm(samples.mean(axis=0) - mean) <= MOMENT_RTOL * np.linalg.norm(mean)
    assert np.linalg.norm(np.cov(samples.T) - cov) <= MOMENT_RTOL * np.linalg.norm(cov)


def test_sampling_is_reproducible_with_the_injected_generator():
    mean, cov = np.zeros((5, 2)), np.tile(np.eye(2), (5, 1, 1))
    a = sample_gaussian(mean, cov, np.random.default_rng(4))
    b = sample_gaussian(mean, cov, np.random.default_rng(4))
    np.testing.assert_array_equal(a, b)
