"""Weights and resampling (thesis eqs. 4.48-4.51, Thrun et al. Table 4.4)."""

from __future__ import annotations

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

from omnislam.fastslam.particles import ParticleSet
from omnislam.fastslam.resampling import (
    coefficient_of_variation,
    effective_sample_size,
    island_bounds,
    island_resample,
    multinomial_resample,
    normalize_log_weights,
    normalize_per_island,
    stratified_resample,
    systematic_resample,
)


def test_normalization_survives_huge_log_likelihoods():
    log_w = np.array([-1e4, -1e4 + 1.0, -2e4])
    w = np.exp(normalize_log_weights(log_w))
    np.testing.assert_allclose(w.sum(), 1.0)
    np.testing.assert_allclose(w[1] / w[0], np.e)


@given(st.lists(st.floats(-50, 0), min_size=2, max_size=40))
def test_ess_equals_thesis_form(log_w):
    """ESS = P / (1 + cv^2) (eq. 4.51) equals 1 / sum w^2."""
    p = len(log_w)
    np.testing.assert_allclose(
        effective_sample_size(np.array(log_w)), p / (1 + coefficient_of_variation(np.array(log_w)))
    )


@settings(max_examples=50)
@given(st.lists(st.floats(0.0, 1.0), min_size=1, max_size=50), st.integers(0, 2**32 - 1))
def test_systematic_resampling_copies_floor_or_ceil(raw, seed):
    weights = np.array(raw) + 1e-3
    weights /= weights.sum()
    ancestors = systematic_resample(weights, np.random.default_rng(seed))
    counts = np.bincount(ancestors, minlength=len(weights))
    expected = len(weights) * weights
    assert np.all(counts >= np.floor(expected - 1e-9))
    assert np.all(counts <= np.ceil(expected + 1e-9))


def test_all_schemes_are_unbiased():
    weights = np.array([0.5, 0.3, 0.15, 0.05])
    rng = np.random.default_rng(1)
    for scheme in (systematic_resample, stratified_resample, multinomial_resample):
        counts = sum(np.bincount(scheme(weights, rng), minlength=4) for _ in range(2000))
        np.testing.assert_allclose(counts / counts.sum(), weights, atol=0.01)


def test_log_evidence_is_the_sum_of_the_weighted_likelihoods():
    """Two particles, likelihoods 1 and 3 at equal weights: p(z_1) = 2; then the weights are
    1/4 and 3/4 and likelihoods 2 and 2/3: p(z_2 | z_1) = 1/2 + 1/2 = 1; resampling leaves
    the sum alone, and a third step with likelihoods 5 and 5 multiplies it by 5."""
    particles = ParticleSet(np.zeros((2, 3)))
    particles.reweight(np.log([1.0, 3.0]))
    np.testing.assert_allclose(particles.log_evidence, np.log(2.0))
    particles.reweight(np.log([2.0, 2.0 / 3.0]))
    np.testing.assert_allclose(particles.log_evidence, np.log(2.0))
    particles.resample(np.array([1, 1]))
    particles.reweight(np.log([5.0, 5.0]))
    np.testing.assert_allclose(particles.log_evidence, np.log(10.0))


def test_islands_are_normalised_and_resampled_apart():
    """Each island's weights sum to 1/K after normalisation, and resampling draws every
    island's particles from its own members only, only in islands whose own ESS is low."""
    bounds = island_bounds(7, 3)
    np.testing.assert_array_equal(bounds, [0, 3, 5, 7])
    log_w = normalize_per_island(np.log([1.0, 1.0, 1.0, 1e-6, 1.0, 2.0, 3.0]), bounds)
    w = np.exp(log_w)
    np.testing.assert_allclose([w[0:3].sum(), w[3:5].sum(), w[5:7].sum()], 1.0 / 3.0)
    rng = np.random.default_rng(0)
    ancestors = island_resample(log_w, bounds, 0.6, systematic_resample, rng)
    assert ancestors is not None
    np.testing.assert_array_equal(ancestors[0:3], [0, 1, 2])  # ESS 3 >= 0.6 * 3: kept
    np.testing.assert_array_equal(ancestors[3:5], [4, 4])  # ESS ~1 < 0.6 * 2: the heavy one
    np.testing.assert_array_equal(ancestors[5:7], [5, 6])  # ESS 1.92 >= 0.6 * 2: kept
    assert (
        island_resample(
            normalize_per_island(np.zeros(7), bounds), bounds, 0.5, systematic_resample, rng
        )
        is None
    )


def test_each_scheme_has_its_own_joint_distribution():
    """Weights (1, 3, 3, 1) / 8 over 4 particles: one systematic draw keeps exactly one of the
    two light particles (u < 1/2 keeps the first, u >= 1/2 the last); stratified draws keep
    each independently with probability 1/2, so both or neither half of the time; multinomial
    draws give them Binomial(4, 1/4) copies together, not one copy with 1 - 4 (1/4) (3/4)^3
    = 0.578. 2000 draws: a standard error of 0.011, the tolerance ~3.5 of them."""
    weights = np.array([1.0, 3.0, 3.0, 1.0]) / 8
    rng = np.random.default_rng(2)
    expected = {systematic_resample: 0.0, stratified_resample: 0.5, multinomial_resample: 0.578}
    for scheme, not_one in expected.items():
        light = [np.isin(scheme(weights, rng), [0, 3]).sum() for _ in range(2000)]
        assert abs(np.mean(np.array(light) != 1) - not_one) < 0.04, scheme.__name__


class _Draw:
    """A generator whose uniform draws are one value of [0, 1): the ends of the interval."""

    def __init__(self, value):
        self.value = value

    def random(self, size=None):
        return self.value if size is None else np.full(size, self.value)


def test_resampling_at_the_ends_of_the_uniform_interval():
    """A draw of 0 puts the pointers on the cumulative sums' steps: with dyadic equal weights
    (exact sums) every particle is copied once. A draw just below 1 rounds the last pointer
    (u + P - 1) / P to 1.0: it must still name a particle (an index < P)."""
    for p in (4, 8):
        for scheme in (systematic_resample, stratified_resample):
            np.testing.assert_array_equal(scheme(np.full(p, 1.0 / p), _Draw(0.0)), np.arange(p))
    for p in (4, 10, 1000):
        for scheme in (systematic_resample, stratified_resample):
            ancestors = scheme(np.full(p, 1.0 / p), _Draw(np.nextafter(1.0, 0.0)))
            assert ancestors.min() >= 0 and ancestors.max() == p - 1, scheme.__name__


def test_island_resampling_with_a_threshold_of_one_always_resamples():
    bounds = island_bounds(6, 2)
    log_w = normalize_per_island(np.zeros(6), bounds)  # ESS equal to the island size
    ancestors = island_resample(log_w, bounds, 1.0, systematic_resample, np.random.default_rng(0))
    assert ancestors is not None
    np.testing.assert_array_equal(ancestors, np.arange(6))
