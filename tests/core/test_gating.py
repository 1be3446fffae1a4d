"""Chi-square validation gates and the gate-truncated likelihood."""

import math

import numpy as np

from omnislam.core.gating import chi_square_gate, gate_truncated_log_likelihood
from omnislam.core.gaussian import log_likelihood_from_mahalanobis


def test_chi_square_gate():
    assert math.isclose(chi_square_gate(0.999, 2), -2.0 * math.log(0.001))
    assert math.isclose(chi_square_gate(0.95, 3), 7.814727903251178)
    assert chi_square_gate(1.0, 2) == math.inf


def test_gate_keeps_its_probability_of_consistent_innovations(rng):
    """y ~ N(0, S): y^T S^-1 y <= gate for the gate's fraction of the draws."""
    gate = chi_square_gate(0.95, 3)
    y = rng.standard_normal((200_000, 3))
    inside = np.mean(np.einsum("ni,ni->n", y, y) <= gate)
    assert abs(inside - 0.95) < 3e-3


def test_truncated_likelihood_is_the_gaussian_inside_and_at_the_gate_outside():
    gate = chi_square_gate(0.999, 2)
    mahalanobis = np.array([0.5, gate, 3.0 * gate, 1e3])
    logdet = np.array([-3.0, -1.0, 0.5, 2.0])
    log_likelihood = log_likelihood_from_mahalanobis(mahalanobis, logdet, 2)
    truncated = gate_truncated_log_likelihood(log_likelihood, mahalanobis, gate)
    np.testing.assert_array_equal(truncated[:2], log_likelihood[:2])
    at_gate = log_likelihood_from_mahalanobis(np.full(2, gate), logdet[2:], 2)
    np.testing.assert_allclose(truncated[2:], at_gate, rtol=1e-12)
    unbounded = gate_truncated_log_likelihood(log_likelihood, mahalanobis, math.inf)
    np.testing.assert_array_equal(unbounded, log_likelihood)
