"""Numerical Jacobians by central differences, on vector spaces and on SE(2) / SE(3).

Used by the tests to check every analytic Jacobian, and by models too intricate to
differentiate by hand. On a manifold the input is perturbed through ``retract(x, delta)`` and
outputs are compared through ``difference(y, y0)``, so angle-valued outputs are wrapped and
SE(3) outputs are compared in the tangent space.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from omnislam.core.se import se3_exp, se3_inverse, se3_log, wrap_angle

Retract = Callable[[np.ndarray, np.ndarray], np.ndarray]
Difference = Callable[[np.ndarray, np.ndarray], np.ndarray]


def numerical_jacobian(
    f: Callable[[np.ndarray], np.ndarray],
    x: np.ndarray,
    *,
    eps: float = 1e-6,
    retract: Retract | None = None,
    tangent_dim: int | None = None,
    difference: Difference | None = None,
) -> np.ndarray:
    """Central-difference Jacobian of ``f`` at ``x``.

    Args:
        f: the function; its output is flattened (or mapped by ``difference``) to a vector.
        x: the point; a vector unless ``retract`` says otherwise (e.g. a 4x4 SE(3) matrix).
        eps: step in each tangent direction.
        retract: ``retract(x, delta)`` -> perturbed point; default ``x + delta`` on a vector.
        tangent_dim: dimension of the tangent space (required with ``retract``).
        difference: ``difference(y, y0)`` -> vector in the output's tangent space; default
            ``(y - y0).ravel()``.

    Returns:
        (m, n) Jacobian, m = output dimension, n = tangent dimension.
    """
    x = np.asarray(x, dtype=float)
    if retract is None:
        flat = x.ravel()

        def retract(point: np.ndarray, delta: np.ndarray) -> np.ndarray:
            return (flat + delta).reshape(x.shape)

        n = flat.size
    else:
        if tangent_dim is None:
            raise ValueError("tangent_dim is required together with retract")
        n = tangent_dim
    if difference is None:

        def difference(y: np.ndarray, y0: np.ndarray) -> np.ndarray:
            return (np.asarray(y, dtype=float) - np.asarray(y0, dtype=float)).ravel()

    y0 = np.asarray(f(x), dtype=float)
    columns = []
    for i in range(n):
        step = np.zeros(n)
        step[i] = eps
        plus = difference(f(retract(x, step)), y0)
        minus = difference(f(retract(x, -step)), y0)
        columns.append((plus - minus) / (2.0 * eps))
    return np.stack(columns, axis=-1)


def angle_difference(angular: tuple[bool, ...]) -> Difference:
    """A ``difference`` that wraps the components flagged in ``angular`` (last axis)."""
    mask = np.asarray(angular)

    def difference(y: np.ndarray, y0: np.ndarray) -> np.ndarray:
        r = np.asarray(y, dtype=float) - np.asarray(y0, dtype=float)
        return np.where(mask, wrap_angle(r), r).ravel()

    return difference


def se2_retract(x: np.ndarray, delta: np.ndarray) -> np.ndarray:
    """Additive perturbation of [x, y, theta] with the angle wrapped."""
    out = np.asarray(x, dtype=float) + delta
    out[2] = wrap_angle(out[2])
    return out


def se3_retract(T: np.ndarray, delta: np.ndarray) -> np.ndarray:
    """Right perturbation ``T * exp(delta)``, delta = [rho, phi] (GTSAM's Pose3 convention)."""
    return np.asarray(T, dtype=float) @ se3_exp(delta)


def se3_difference(T: np.ndarray, T0: np.ndarray) -> np.ndarray:
    """``log(T0^-1 T)``: the local coordinates of T around T0 (inverse of ``se3_retract``)."""
    return se3_log(se3_inverse(T0) @ np.asarray(T, dtype=float))
