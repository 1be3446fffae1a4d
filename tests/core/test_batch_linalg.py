"""The entry-major small-matrix algebra against numpy's stacked matrix algebra (its oracle)."""

import numpy as np
import pytest

from omnislam.core.batch_linalg import (
    cholesky_jittered,
    entry_major,
    inverse_3x3_entry_major,
    inverse_and_logdet,
    inverse_entry_major,
    product,
    quadratic_form,
    stack_major,
    symmetrised,
    transpose,
    transposed,
)


def _spd(rng, shape, k):
    C = rng.normal(size=(*shape, k, k))
    return C @ np.swapaxes(C, -1, -2) + np.eye(k)


@pytest.mark.parametrize("k", [1, 2, 3, 4])
def test_entry_major_algebra_matches_matmul(rng, k):
    """The entry-major products, inverse and quadratic form used by the EKF and the proposal
    equal numpy's stacked matrix algebra (k <= 2 closed form, LAPACK beyond)."""
    n = 7
    A, B = rng.normal(size=(n, k, 3)), rng.normal(size=(n, 3, k))
    C = rng.normal(size=(n, k, k))
    S = _spd(rng, (n,), k)
    y = rng.normal(size=(n, k))
    product_em = stack_major(product(entry_major(A), entry_major(B)))
    np.testing.assert_allclose(product_em, A @ B, rtol=1e-12)
    np.testing.assert_allclose(
        stack_major(symmetrised(entry_major(C))), 0.5 * (C + np.swapaxes(C, 1, 2)), rtol=1e-12
    )
    np.testing.assert_array_equal(stack_major(transposed(entry_major(C))), transpose(C))
    inverse, logdet = inverse_entry_major(entry_major(S))
    np.testing.assert_allclose(stack_major(inverse), np.linalg.inv(S), rtol=1e-9)
    np.testing.assert_allclose(logdet, np.linalg.slogdet(S)[1], rtol=1e-12)
    quadratic = quadratic_form(entry_major(y[..., None]), entry_major(np.linalg.inv(S)))
    np.testing.assert_allclose(quadratic, np.einsum("ni,nij,nj->n", y, np.linalg.inv(S), y))


@pytest.mark.parametrize("k", [1, 2, 3])
def test_stack_major_inverse_and_logdet_match_numpy(rng, k):
    """Closed forms for k <= 2 on any stack shape (association uses (P, K, C, k, k))."""
    S = _spd(rng, (3, 4, 5), k)
    inverse, logdet = inverse_and_logdet(S)
    np.testing.assert_allclose(inverse, np.linalg.inv(S), rtol=1e-9)
    np.testing.assert_allclose(logdet, np.linalg.slogdet(S)[1], rtol=1e-12)


def test_layouts_round_trip_exactly(rng):
    a = rng.normal(size=(4, 5, 2, 3))
    em = entry_major(a)
    assert em.shape == (2, 3, 4, 5) and em.flags.c_contiguous
    np.testing.assert_array_equal(stack_major(em), a)


def test_inverse_3x3_of_non_symmetric_matrices(rng):
    M = rng.normal(size=(6, 3, 3)) + 3 * np.eye(3)
    inverse, det = inverse_3x3_entry_major(entry_major(M))
    np.testing.assert_allclose(stack_major(inverse), np.linalg.inv(M), rtol=1e-10)
    np.testing.assert_allclose(det, np.linalg.det(M), rtol=1e-12)


def test_jittered_cholesky_factorises_a_singular_covariance():
    """A robot turning on the spot: rank-1 pose covariance."""
    cov = np.zeros((2, 3, 3))
    cov[:, 2, 2] = [0.01, 0.04]
    with pytest.raises(np.linalg.LinAlgError):
        np.linalg.cholesky(cov)
    L = cholesky_jittered(cov, 1e-12)
    np.testing.assert_allclose(L @ transpose(L), cov + 1e-12 * np.eye(3), atol=1e-15)
    np.testing.assert_array_equal(np.triu(L, 1), 0.0)


def test_rows_dot_and_norm_are_numpys_reductions_bit_for_bit(rng):
    """The explicit (p0 + p1) + p2 is numpy's order for a 3-element reduction: FastSLAM's
    triangulations give the same bits with either."""
    from omnislam.core.batch_linalg import rows_dot, rows_norm

    a = rng.normal(size=(5000, 3)) * rng.uniform(0, 1e3, size=(5000, 1))
    b = rng.normal(size=(5000, 3))
    np.testing.assert_array_equal(rows_dot(a, b), np.sum(a * b, axis=-1))
    np.testing.assert_array_equal(rows_norm(a), np.linalg.norm(a, axis=-1))
    stack = a.reshape(50, 100, 3)
    np.testing.assert_array_equal(rows_norm(stack), np.linalg.norm(stack, axis=-1))
