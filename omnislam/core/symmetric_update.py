"""In-place symmetric rank-2k corrections of a large covariance held as its upper triangle.

EKF-SLAM corrects its (d x d) covariance with P <- P - (A B^T + B A^T), a symmetric rank-2k
product (the Joseph form of the update, ``ekfslam.state``), O(d^2 k) per frame: on omni data
(d ~ 3000, k ~ 80) this one product is nearly all of the filter's time. BLAS has the exact
routine, ``dsyr2k``, which computes only one triangle (half the arithmetic of the full
product) in place, with the matrix given by a leading dimension -- so the top-left (d x d)
view of a larger preallocated P is updated where it lies, with no temporary and no copy.
numpy does not expose it, and scipy's ``scipy.linalg.blas.dsyr2k`` takes no leading dimension
(it would copy the non-contiguous view of P, twice the work it saves). scipy does export the
BLAS it links as C function pointers for Cython (``scipy.linalg.cython_blas``, a public,
stable API); ``syr2k_upper`` calls that ``dsyr2k`` through ``ctypes`` with the view's own
leading dimension.

Layout: P is a C-ordered (row-major) view with unit column stride, so to BLAS (column-major)
it is P^T with leading dimension = P's row stride; P's *upper* triangle (j >= i) is BLAS's
*lower* one. The lower triangle of P is neither read nor written.

``syr2k_upper_numpy`` is the readable reference (panels of rows, each the upper part of
A B^T + B A^T): the tests check the BLAS path against it, and it is used where the BLAS
symbol cannot be found.
"""

from __future__ import annotations

import ctypes
import functools

import numpy as np

#: rows per panel of the numpy reference
PANEL_ROWS = 256

#: void dsyr2k(char *uplo, char *trans, int *n, int *k, double *alpha, double *a, int *lda,
#:             double *b, int *ldb, double *beta, double *c, int *ldc)  (scipy.linalg.cython_blas);
#: every argument a pointer, passed as an address (no per-call ctypes casts)
_DSYR2K = ctypes.CFUNCTYPE(None, *([ctypes.c_void_p] * 12))
#: the constant arguments: 'L', 'T', alpha = -1, beta = 1 (never written by BLAS)
_LOWER, _TRANSPOSED = ctypes.c_char(b"L"), ctypes.c_char(b"T")
_MINUS_ONE, _ONE = ctypes.c_double(-1.0), ctypes.c_double(1.0)


@functools.lru_cache(maxsize=1)
def _dsyr2k() -> object | None:
    """scipy's ``dsyr2k`` as a ctypes function, or None when it cannot be found."""
    try:
        from scipy.linalg import cython_blas

        capsule = cython_blas.__pyx_capi__["dsyr2k"]
        api = ctypes.pythonapi
        api.PyCapsule_GetName.restype = ctypes.c_char_p
        api.PyCapsule_GetName.argtypes = [ctypes.py_object]
        api.PyCapsule_GetPointer.restype = ctypes.c_void_p
        api.PyCapsule_GetPointer.argtypes = [ctypes.py_object, ctypes.c_char_p]
        pointer = api.PyCapsule_GetPointer(capsule, api.PyCapsule_GetName(capsule))
    except (ImportError, AttributeError, KeyError, ValueError):  # pragma: no cover - no scipy BLAS
        return None
    if not pointer:  # pragma: no cover
        return None
    return _DSYR2K(pointer)


def blas_available() -> bool:
    """Whether ``syr2k_upper`` runs BLAS's ``dsyr2k`` (else the numpy reference)."""
    return _dsyr2k() is not None


def _check(P: np.ndarray, A: np.ndarray, B: np.ndarray) -> None:
    if P.ndim != 2 or P.shape[0] != P.shape[1]:
        raise ValueError(f"P must be square, got {P.shape}")
    if P.dtype != np.float64 or P.strides[1] != P.itemsize or not P.flags.writeable:
        raise ValueError("P must be a writeable float64 view with unit column stride")
    if A.shape != B.shape or A.ndim != 2 or A.shape[0] != P.shape[0]:
        raise ValueError(f"A and B must both be ({P.shape[0]}, k), got {A.shape} and {B.shape}")


def syr2k_upper(P: np.ndarray, A: np.ndarray, B: np.ndarray) -> None:
    """P <- P - (A B^T + B A^T) on the upper triangle of P, in place (BLAS ``dsyr2k``).

    Args:
        P: (d, d) float64 view with unit column stride (e.g. the top-left block of a larger
            C-ordered array); only its upper triangle (j >= i) is read and written.
        A: (d, k).
        B: (d, k).
    """
    _check(P, A, B)
    d, k = A.shape
    if d == 0 or k == 0:
        return
    dsyr2k = _dsyr2k()
    if dsyr2k is None:  # pragma: no cover - exercised through syr2k_upper_numpy's tests
        syr2k_upper_numpy(P, A, B)
        return
    A = np.ascontiguousarray(A, dtype=np.float64)
    B = np.ascontiguousarray(B, dtype=np.float64)
    # n, k, lda = ldb, ldc in one int array (each call its own: BLAS runs without the GIL)
    ints = np.array([d, k, k, P.strides[0] // P.itemsize], dtype=np.intc)
    at = ints.ctypes.data
    size = ints.itemsize
    # column-major view: P^T (lower = P's upper); A, B are (k x d) with A^T = our A
    dsyr2k(  # type: ignore[operator]
        ctypes.addressof(_LOWER),
        ctypes.addressof(_TRANSPOSED),
        at,
        at + size,
        ctypes.addressof(_MINUS_ONE),
        A.ctypes.data,
        at + 2 * size,
        B.ctypes.data,
        at + 2 * size,
        ctypes.addressof(_ONE),
        P.ctypes.data,
        at + 3 * size,
    )


def syr2k_upper_numpy(P: np.ndarray, A: np.ndarray, B: np.ndarray) -> None:
    """The reference of ``syr2k_upper`` in numpy: panel by panel of ``PANEL_ROWS`` rows, the
    upper part of each panel's rows of A B^T + B A^T (about half the full product)."""
    _check(P, A, B)
    d = P.shape[0]
    for start in range(0, d, PANEL_ROWS):
        stop = min(start + PANEL_ROWS, d)
        panel = A[start:stop] @ B[start:].T + B[start:stop] @ A[start:].T
        rows, cols = np.triu_indices(stop - start)
        tile = P[start:stop, start:stop]
        tile[rows, cols] -= panel[rows, cols]
        P[start:stop, stop:] -= panel[:, stop - start :]


def symmetric_from_upper(P: np.ndarray) -> np.ndarray:
    """(d, d) symmetric copy of a matrix whose upper triangle holds it."""
    upper = np.triu(P)
    return upper + np.triu(P, 1).T
