"""Radial-tangential (Brown-Conrady) distortion on the normalised image plane.

The form used by OpenCV, Bouguet's toolbox and Mei's omnidirectional toolbox (Mei & Rives
2007, eq. 6): with ``rho^2 = x^2 + y^2``,

    x_d = x (1 + k1 rho^2 + k2 rho^4) + 2 p1 x y + p2 (rho^2 + 2 x^2)
    y_d = y (1 + k1 rho^2 + k2 rho^4) + p1 (rho^2 + 2 y^2) + 2 p2 x y

Shared by :mod:`~omnislam.camera.pinhole` and :mod:`~omnislam.camera.unified`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: convergence threshold of the undistortion on the normalised plane (dimensionless)
UNDISTORT_TOL = 1e-13
#: iteration cap of the undistortion Newton solve
UNDISTORT_MAX_ITER = 30


@dataclass(frozen=True, slots=True)
class RadialTangential:
    """Coefficients ``k1, k2`` (radial) and ``p1, p2`` (tangential), all dimensionless."""

    k1: float = 0.0
    k2: float = 0.0
    p1: float = 0.0
    p2: float = 0.0

    @property
    def is_zero(self) -> bool:
        """True when the distortion is the identity."""
        return self.k1 == 0.0 and self.k2 == 0.0 and self.p1 == 0.0 and self.p2 == 0.0

    def distort(self, m_u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Distort normalised points and return the Jacobian.

        Args:
            m_u: (N, 2) undistorted normalised coordinates ``[x, y]``.

        Returns:
            ``(m_d, J)``: (N, 2) distorted coordinates and (N, 2, 2) ``d m_d / d m_u``.
        """
        x, y = m_u[:, 0], m_u[:, 1]
        rho2 = x * x + y * y
        radial = 1.0 + rho2 * (self.k1 + self.k2 * rho2)
        m_d = np.column_stack(
            [
                x * radial + 2.0 * self.p1 * x * y + self.p2 * (rho2 + 2.0 * x * x),
                y * radial + self.p1 * (rho2 + 2.0 * y * y) + 2.0 * self.p2 * x * y,
            ]
        )
        slope = 2.0 * (self.k1 + 2.0 * self.k2 * rho2)  # d radial / d(rho^2) * 2
        J = np.empty((len(x), 2, 2))
        J[:, 0, 0] = radial + slope * x * x + 2.0 * self.p1 * y + 6.0 * self.p2 * x
        J[:, 0, 1] = slope * x * y + 2.0 * self.p1 * x + 2.0 * self.p2 * y
        J[:, 1, 0] = slope * x * y + 2.0 * self.p1 * x + 2.0 * self.p2 * y
        J[:, 1, 1] = radial + slope * y * y + 6.0 * self.p1 * y + 2.0 * self.p2 * x
        return m_d, J

    def is_monotonic(self, m_u: np.ndarray) -> np.ndarray:
        """(N,) True where the radial term still grows with rho.

        ``d/drho [rho (1 + k1 rho^2 + k2 rho^4)] = 1 + 3 k1 rho^2 + 5 k2 rho^4``: beyond its
        first zero the polynomial folds back and distant points re-enter the image, so a
        projection there is rejected.
        """
        rho2 = m_u[:, 0] ** 2 + m_u[:, 1] ** 2
        return 1.0 + rho2 * (3.0 * self.k1 + 5.0 * self.k2 * rho2) > 0.0

    def undistort(self, m_d: np.ndarray) -> np.ndarray:
        """Invert ``distort`` by Newton's method started at ``m_d``.

        Converged when the residual ``|distort(m) - m_d|`` is below ``UNDISTORT_TOL``
        (relative to ``1 + |m_d|``) within ``UNDISTORT_MAX_ITER`` steps **and** the solution
        lies on the monotonic branch (``is_monotonic``); other rows are NaN.

        Args:
            m_d: (N, 2) distorted normalised coordinates.

        Returns:
            (N, 2) undistorted normalised coordinates.
        """
        m_d = np.asarray(m_d, dtype=float)
        if self.is_zero:
            return m_d.copy()
        m_u = m_d.copy()
        scale = 1.0 + np.linalg.norm(m_d, axis=1)
        converged = np.zeros(len(m_d), dtype=bool)
        for _ in range(UNDISTORT_MAX_ITER):
            active = ~converged & np.all(np.isfinite(m_u), axis=1)
            if not np.any(active):
                break
            guess, J = self.distort(m_u[active])
            residual = guess - m_d[active]
            done = np.linalg.norm(residual, axis=1) <= UNDISTORT_TOL * scale[active]
            step = _solve2(J, residual)
            index = np.flatnonzero(active)
            converged[index[done]] = True
            m_u[index[~done]] -= step[~done]
        ok = converged & self.is_monotonic(np.nan_to_num(m_u))
        m_u[~ok] = np.nan
        return m_u


def _solve2(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Solve (N, 2, 2) systems ``A x = b`` in closed form; NaN rows where ``A`` is singular."""
    det = A[:, 0, 0] * A[:, 1, 1] - A[:, 0, 1] * A[:, 1, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        x0 = (A[:, 1, 1] * b[:, 0] - A[:, 0, 1] * b[:, 1]) / det
        x1 = (A[:, 0, 0] * b[:, 1] - A[:, 1, 0] * b[:, 0]) / det
    out = np.column_stack([x0, x1])
    out[~np.isfinite(out).all(axis=1)] = np.nan
    return out
