"""core.symmetric_update: BLAS dsyr2k on a view of a larger array, against numpy and the dense
product."""

from __future__ import annotations

import numpy as np
import pytest

from omnislam.core.symmetric_update import (
    blas_available,
    symmetric_from_upper,
    syr2k_upper,
    syr2k_upper_numpy,
)


def _case(d: int, k: int, capacity: int, seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    rng = np.random.default_rng(seed)
    M = rng.standard_normal((d, d))
    big = rng.standard_normal((capacity, capacity))  # garbage outside the top-left block
    big[:d, :d] = M @ M.T
    return big, rng.standard_normal((d, k)), rng.standard_normal((d, k))


def test_the_blas_routine_is_found():
    assert blas_available()


@pytest.mark.parametrize("update", [syr2k_upper, syr2k_upper_numpy])
@pytest.mark.parametrize(("d", "k"), [(7, 1), (256, 6), (700, 80)])
def test_upper_triangle_of_a_view_is_the_dense_rank_2k_correction(update, d, k):
    big, A, B = _case(d, k, capacity=d + 13, seed=d + k)
    before = big.copy()
    expected = big[:d, :d] - (A @ B.T + B @ A.T)
    update(big[:d, :d], A, B)  # leading dimension d + 13: updated where it lies
    upper = np.triu_indices(d)
    tol = 1e-12 * np.abs(expected).max()
    np.testing.assert_allclose(big[:d, :d][upper], expected[upper], rtol=0, atol=tol)
    lower = np.tril_indices(d, -1)
    assert np.array_equal(big[:d, :d][lower], before[:d, :d][lower])  # never written
    assert np.array_equal(big[d:], before[d:]) and np.array_equal(big[:, d:], before[:, d:])
    np.testing.assert_allclose(symmetric_from_upper(big[:d, :d]), expected, rtol=0, atol=tol)


def test_blas_and_numpy_paths_agree():
    big, A, B = _case(300, 40, capacity=333, seed=1)
    a, b = big.copy(), big.copy()
    syr2k_upper(a[:300, :300], A, B)
    syr2k_upper_numpy(b[:300, :300], A, B)
    upper = np.triu_indices(300)
    np.testing.assert_allclose(a[:300, :300][upper], b[:300, :300][upper], rtol=0, atol=1e-10)


def test_no_columns_is_a_no_op():
    big, _, _ = _case(5, 1, capacity=5, seed=2)
    before = big.copy()
    syr2k_upper(big, np.zeros((5, 0)), np.zeros((5, 0)))
    assert np.array_equal(big, before)


@pytest.mark.parametrize(
    ("P", "A", "B"),
    [
        (np.zeros((4, 5)), np.zeros((4, 1)), np.zeros((4, 1))),  # not square
        (np.zeros((4, 4), dtype=np.float32), np.zeros((4, 1)), np.zeros((4, 1))),  # dtype
        (np.zeros((4, 8))[:, ::2], np.zeros((4, 1)), np.zeros((4, 1))),  # column stride
        (np.zeros((4, 4)), np.zeros((4, 1)), np.zeros((4, 2))),  # A, B differ
        (np.zeros((4, 4)), np.zeros((3, 1)), np.zeros((3, 1))),  # wrong rows
    ],
)
def test_bad_shapes_and_layouts_are_refused(P, A, B):
    with pytest.raises(ValueError):
        syr2k_upper(P, A, B)
