"""Unified sphere model of central catadioptric cameras (Geyer & Daniilidis 2000; Mei & Rives 2007).

Projection (Mei & Rives 2007, eqs. 1-6), in the standard frame (``z`` along the optical axis,
``x`` along image columns, ``y`` along rows):

1. onto the unit sphere: ``X_s = X / |X|``;
2. from the point ``(0, 0, -xi)`` onto the normalised plane:
   ``m_u = [x_s, y_s] / (z_s + xi)``;
3. radial-tangential distortion ``m_d = D(m_u)`` (:mod:`omnislam.camera.distortion`);
4. generalised camera matrix: ``u = gamma1 m_x + skew m_y + cu``, ``v = gamma2 m_y + cv``.

``xi = 0`` is a pinhole, ``xi = 1`` a parabolic mirror with an orthographic camera,
``0 < xi < 1`` a hyperbolic mirror (see :func:`hyperbolic_to_unified`).

Validity. Step 2 is one-to-one only for ``z_s > -xi`` when ``xi <= 1`` and for
``z_s > -1/xi`` when ``xi > 1`` (Mei & Rives 2007, section II-A); points beyond are not
projectable, and neither are points past the turning point of the radial distortion.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from omnislam.camera.base import (
    CameraModel,
    as_pixels,
    as_points,
    check_image_size,
    check_positive,
    check_principal_point,
    in_ring,
)
from omnislam.camera.distortion import RadialTangential
from omnislam.camera.hyperbolic import HyperbolicCamera
from omnislam.errors import DataError


@dataclass(frozen=True, slots=True)
class UnifiedCamera(CameraModel):
    """Mei's unified sphere model with radial-tangential distortion.

    Attributes:
        xi: sphere-to-projection-centre distance ``xi >= 0`` (dimensionless).
        gamma1: generalised focal length along u [px].
        gamma2: generalised focal length along v [px].
        cu: principal point column [px].
        cv: principal point row [px].
        width: image width [px].
        height: image height [px].
        skew: ``K[0, 1]`` [px] (0 for square-grid sensors).
        k1, k2: radial distortion on the normalised plane (dimensionless).
        p1, p2: tangential distortion on the normalised plane (dimensionless).
        inner_radius_px: radius of the masked inner disc about ``(cu, cv)`` [px].
        outer_radius_px: radius of the usable region about ``(cu, cv)`` [px]; None = no limit.
    """

    MODEL: ClassVar[str] = "unified"

    xi: float
    gamma1: float
    gamma2: float
    cu: float
    cv: float
    width: int
    height: int
    skew: float = 0.0
    k1: float = 0.0
    k2: float = 0.0
    p1: float = 0.0
    p2: float = 0.0
    inner_radius_px: float = 0.0
    outer_radius_px: float | None = None

    def __post_init__(self) -> None:
        check_image_size(self.width, self.height, "UnifiedCamera")
        check_principal_point(
            float(self.cu), float(self.cv), self.width, self.height, "UnifiedCamera"
        )
        check_positive(self.gamma1, "UnifiedCamera.gamma1")
        check_positive(self.gamma2, "UnifiedCamera.gamma2")
        if not np.isfinite(self.xi) or self.xi < 0.0:
            raise DataError(f"UnifiedCamera.xi must be finite and >= 0, got {self.xi!r}")
        if self.inner_radius_px < 0.0 or (
            self.outer_radius_px is not None and self.outer_radius_px <= self.inner_radius_px
        ):
            raise DataError(
                "UnifiedCamera mask radii must satisfy 0 <= inner_radius_px < outer_radius_px, "
                f"got {self.inner_radius_px!r}, {self.outer_radius_px!r}"
            )

    @property
    def distortion(self) -> RadialTangential:
        """The distortion coefficients as one object."""
        return RadialTangential(self.k1, self.k2, self.p1, self.p2)

    @property
    def min_z_s(self) -> float:
        """Lowest ``z_s`` of a projectable unit vector: ``-xi`` (xi <= 1) or ``-1/xi``."""
        return -self.xi if self.xi <= 1.0 else -1.0 / self.xi

    def project(self, points_c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Project points of the camera frame to pixels (Mei & Rives 2007, eqs. 1-6).

        Args:
            points_c: (N, 3) points in the camera frame [m].

        Returns:
            ``(pixels, valid)``: (N, 2) [px], NaN where not projectable; (N,) projectable and
            inside the image.
        """
        points_c = as_points(points_c)
        norm_m = np.linalg.norm(points_c, axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            sphere = points_c / norm_m[:, None]
            projectable = sphere[:, 2] > self.min_z_s
            m_u = sphere[:, :2] / (sphere[:, 2:] + self.xi)
        m_u[~projectable] = np.nan
        distortion = self.distortion
        m_d, _ = distortion.distort(m_u)
        m_d[~distortion.is_monotonic(m_u)] = np.nan
        pixels = self._to_pixels(m_d)
        valid = np.all(np.isfinite(pixels), axis=1) & self.in_image(pixels)
        return pixels, valid

    def unproject(self, pixels: np.ndarray) -> np.ndarray:
        """Rays of pixels: inverse camera matrix, undistortion, lift onto the sphere.

        Undistortion is exact (identity) without distortion and Newton's method otherwise
        (``RadialTangential.undistort``, with a convergence check). The lift inverts step 2
        in closed form (Mei & Rives 2007, eq. 8): with ``r^2 = |m_u|^2``,
        ``eta = (xi + sqrt(1 + (1 - xi^2) r^2)) / (1 + r^2)`` and
        ``X_s = [eta m_x, eta m_y, eta - xi]``; for ``xi > 1`` the image is bounded by
        ``r^2 <= 1 / (xi^2 - 1)``.

        Args:
            pixels: (N, 2) ``[u, v]`` [px].

        Returns:
            (N, 3) unit rays in the camera frame; NaN rows where no ray exists.
        """
        pixels = as_pixels(pixels)
        m_y = (pixels[:, 1] - self.cv) / self.gamma2
        m_x = (pixels[:, 0] - self.cu - self.skew * m_y) / self.gamma1
        m_u = self.distortion.undistort(np.column_stack([m_x, m_y]))
        r2 = np.einsum("ij,ij->i", m_u, m_u)
        radicand = 1.0 + (1.0 - self.xi**2) * r2
        with np.errstate(invalid="ignore"):
            eta = (self.xi + np.sqrt(np.where(radicand >= 0.0, radicand, np.nan))) / (1.0 + r2)
        rays_c = np.column_stack([eta * m_u[:, 0], eta * m_u[:, 1], eta - self.xi])
        # |X_s| = 1 analytically; renormalising removes the last ulps of rounding.
        return rays_c / np.linalg.norm(rays_c, axis=1, keepdims=True)

    def project_jacobian(self, points_c: np.ndarray) -> np.ndarray:
        """Analytic ``d[u, v]/dX`` = ``K @ dD/dm_u @ dm_u/dX``.

        With ``rho = |X|`` and ``w = Z + xi rho`` (so ``m_u = [X, Y] / w``):
        ``dm_x/dX = e_x / w - X (e_z + xi X / rho)^T / w^2`` (same for ``y``).

        Args:
            points_c: (N, 3) points in the camera frame [m].

        Returns:
            (N, 2, 3) [px/m]; NaN where not projectable.
        """
        points_c = as_points(points_c)
        rho = np.linalg.norm(points_c, axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            projectable = points_c[:, 2] / rho > self.min_z_s
            w = points_c[:, 2] + self.xi * rho
            dw_dX = np.zeros_like(points_c)
            dw_dX[:, 2] = 1.0
            dw_dX += self.xi * points_c / rho[:, None]
            m_u = points_c[:, :2] / w[:, None]
            dm_dX = np.zeros((len(points_c), 2, 3))
            dm_dX[:, 0, 0] = 1.0 / w
            dm_dX[:, 1, 1] = 1.0 / w
            dm_dX -= (points_c[:, :2, None] * dw_dX[:, None, :]) / (w**2)[:, None, None]
        _, dD_dm = self.distortion.distort(m_u)
        K = np.array([[self.gamma1, self.skew], [0.0, self.gamma2]])
        J = K @ dD_dm @ dm_dX
        J[~projectable] = np.nan
        return J

    def in_mask(self, pixels: np.ndarray) -> np.ndarray:
        """(N,) True inside the image on the ring ``inner_radius_px <= R <= outer_radius_px``."""
        pixels = as_pixels(pixels)
        return self.in_image(pixels) & in_ring(
            pixels, self.cu, self.cv, self.inner_radius_px, self.outer_radius_px
        )

    def _to_pixels(self, m_d: np.ndarray) -> np.ndarray:
        """Apply the generalised camera matrix to distorted normalised coordinates."""
        return np.column_stack(
            [
                self.gamma1 * m_d[:, 0] + self.skew * m_d[:, 1] + self.cu,
                self.gamma2 * m_d[:, 1] + self.cv,
            ]
        )


#: ``R_us`` of :func:`hyperbolic_to_unified`: the mirror reflection z -> -z (det = -1)
R_US_REFLECTION = np.diag([1.0, 1.0, -1.0])
R_US_REFLECTION.setflags(write=False)


def hyperbolic_to_unified(h: HyperbolicCamera) -> tuple[UnifiedCamera, np.ndarray]:
    """The unified-model camera that images exactly like a hyperbolic-mirror camera.

    Derivation. For a direction ``r`` from ``F2`` (frame ``S`` of :mod:`hyperbolic`) the
    mirror point is ``P = mu r`` with ``mu = b^2 / (a - e r_z)``, and the pinhole at
    ``F1 = (0, 0, -2e)`` images it at ``c + k [P_x, P_y] / (P_z + 2e)``, ``k = f / pixel``.
    Substituting ``mu``:

        P_x / (P_z + 2e) = b^2 r_x / (b^2 r_z + 2e (a - e r_z))
                         = b^2 r_x / (2ae - (a^2 + e^2) r_z)           [b^2 - 2e^2 = -(a^2 + e^2)]
                         = [b^2 / (a^2 + e^2)] r_x / (xi - r_z),   xi = 2ae / (a^2 + e^2).

    With ``X_u = R_us r``, ``R_us = diag(1, 1, -1)``, this is the unified projection
    ``x_s / (z_s + xi)`` times ``gamma = k b^2 / (a^2 + e^2)``. In the usual notation
    (mirror focal distance ``d = 2e``, latus rectum ``4p = 2 b^2 / a``, so ``2p = b^2 / a``):
    ``sqrt(d^2 + 4p^2) = sqrt(4 a^2 e^2 + b^4) / a = (a^2 + e^2) / a`` because
    ``b^4 = (e^2 - a^2)^2``; hence ``xi = d / sqrt(d^2 + 4p^2)`` and
    ``gamma = k 2p / sqrt(d^2 + 4p^2)``, the known results (Geyer & Daniilidis 2000;
    Barreto & Araujo 2005). ``0 < xi < 1``, and ``xi > a/e`` so every direction the mirror
    can image (``r_z < a/e``) satisfies the unified validity test ``z_s > -xi``.

    Frame choice. A catadioptric image is a mirror image: the unified model with positive
    ``gamma`` (and ``z`` pointing from the sphere towards the scene it images best) describes
    it in a frame that is the reflection ``z -> -z`` of ``S``, so ``R_us`` is an improper
    orthogonal matrix (det -1), not a rotation. Keep it when mounting the unified camera on
    a rig (``rTu = rTs @ R_us.T``, see :class:`~omnislam.camera.rig.CameraRig`).

    Args:
        h: the hyperbolic-mirror camera.

    Returns:
        ``(unified, R_us)``: the equivalent camera (same image size, principal point and mask
        radii, no distortion) and (3, 3) ``R_us`` mapping ``S`` vectors into its frame.
    """
    a2 = h.a_m**2
    e2 = h.e_m**2
    xi = 2.0 * h.a_m * h.e_m / (a2 + e2)
    gamma = h.focal_px * h.b_m**2 / (a2 + e2)
    unified = UnifiedCamera(
        xi=xi,
        gamma1=gamma,
        gamma2=gamma,
        cu=h.cu,
        cv=h.cv,
        width=h.width,
        height=h.height,
        inner_radius_px=h.inner_radius_px,
        outer_radius_px=h.outer_radius_px,
    )
    return unified, R_US_REFLECTION.copy()
