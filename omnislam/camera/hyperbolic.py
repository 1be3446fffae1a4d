"""Central catadioptric camera with a hyperbolic mirror (thesis section 4.3, eqs. 4.18-4.20).

Geometry (thesis Fig. 3.3a / 4.7). The mirror is one sheet of the hyperboloid

    (z_F1 - z_h)^2 / a^2 - (x^2 + y^2) / b^2 = 1,            e = sqrt(a^2 + b^2),

written (as in the thesis) in coordinates whose origin is the pinhole ``F1`` of a perspective
camera looking up the mirror axis. Its foci are ``F1`` (``z_F1 = z_h - e``) and
``F2`` (``z_F1 = z_h + e``); the camera sees every ray aimed at ``F2`` after one reflection,
which makes ``F2`` the single effective viewpoint **only if** the pinhole is at the outer
focus, ``z_h = e`` (Baker & Nayar 1999). This model enforces it.

Frame ``S`` of this model (``points_c`` / ``rays_c``): origin at ``F2``, ``z`` up the mirror
axis (from the camera towards the mirror), ``x`` and ``y`` parallel to the pinhole camera's
``x`` (image columns) and ``y`` (image rows). In ``S`` the mirror is

    (z + e)^2 / a^2 - (x^2 + y^2) / b^2 = 1,    z + e >= a    (the sheet around F2)

and the pinhole sits at ``F1 = (0, 0, -2e)``. A direction straight down (-z) images at the
principal point (it sees the camera itself, masked out); ``u`` grows with ``+x`` and ``v``
with ``+y``. Seen from the world the image is mirrored, but ``S`` is a proper right-handed
frame: no reflection is needed to mount it on a robot.

Closed forms used below (derived in the docstrings, checked numerically in the tests):

- mirror point of a direction ``r`` from ``F2``: ``P = mu r`` with ``mu = b^2 / (a - e r_z)``,
  which exists iff ``r_z < a / e`` (above that the ray escapes between the asymptotes);
- pixel radius at elevation ``phi``: ``R = gamma cos(phi) / (xi - sin(phi))`` with
  ``xi = 2 a e / (a^2 + e^2)`` and ``gamma = (f / pixel) b^2 / (a^2 + e^2)`` - the unified-model
  parameters of :func:`omnislam.camera.unified.hyperbolic_to_unified`.

Angular noise. Differentiating ``R(phi)``: radial resolution ``dR/dphi = gamma (1 - xi sin
phi) / (xi - sin phi)^2`` and tangential resolution ``gamma / (xi - sin phi)`` px/rad both
*grow* with elevation, so isotropic pixel noise costs **less** angle towards the rim
(``angular_sigma = sigma_px (xi - sin phi) / gamma``, ~2.9x smaller at the rim than at the
inner mask radius for the defaults). The loss of resolution towards the rim that the thesis
describes (3.6, Fig. 3.4) is a loss of *ground* resolution: near the horizon a small
elevation error is a large error in the range of a landmark, which the estimators' range /
triangulation uncertainty carries, not the bearing noise.
"""

from __future__ import annotations

import math
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
from omnislam.errors import DataError

#: relative tolerance on z_h = e (the single-viewpoint condition)
CENTRAL_RTOL = 1e-9


@dataclass(frozen=True, slots=True)
class HyperbolicCamera(CameraModel):
    """Perspective camera at the outer focus of a hyperbolic mirror (thesis 4.3).

    Defaults: the Svoboda & Pajdla mirror (a = 28.1 mm, b = 23.4 mm; asymptote at 50.2 deg
    elevation) seen by a 6.2 mm lens with 8 um pixels on a 640 x 640 sensor. The 33 mm rim
    images at ~300 px radius and limits the view to +20.1 deg above the horizon; the horizon
    images at ~206 px; directions below -60 deg (the camera's own reflection, < 54 px) are
    masked out.

    Attributes:
        a_m: hyperboloid semi-axis along the mirror axis, ``a`` [m].
        b_m: hyperboloid transverse semi-axis, ``b`` [m].
        focal_length_m: focal length ``f`` of the perspective camera [m].
        pixel_size_m: side of a (square) pixel [m].
        cu: principal point column [px] (pixel-centre convention, see ``base``).
        cv: principal point row [px].
        width: image width [px].
        height: image height [px].
        rim_radius_m: radius of the mirror rim about its axis [m]; its image bounds the mask.
        min_elevation_rad: directions below this elevation see the camera's own reflection
            and fall inside the masked inner disc [rad].
        z_h_m: height of the hyperboloid centre above the pinhole ``F1`` [m] (thesis ``z_h``);
            must equal ``e = sqrt(a^2 + b^2)`` (single viewpoint); None means ``e``.
    """

    MODEL: ClassVar[str] = "hyperbolic"

    a_m: float = 0.0281
    b_m: float = 0.0234
    focal_length_m: float = 6.2e-3
    pixel_size_m: float = 8.0e-6
    cu: float = 319.5
    cv: float = 319.5
    width: int = 640
    height: int = 640
    rim_radius_m: float = 0.033
    min_elevation_rad: float = -math.pi / 3.0
    z_h_m: float | None = None

    def __post_init__(self) -> None:
        check_image_size(self.width, self.height, "HyperbolicCamera")
        check_principal_point(
            float(self.cu), float(self.cv), self.width, self.height, "HyperbolicCamera"
        )
        for label in ("a_m", "b_m", "focal_length_m", "pixel_size_m", "rim_radius_m"):
            check_positive(getattr(self, label), f"HyperbolicCamera.{label}")
        e_m = self.e_m
        if self.z_h_m is None:
            object.__setattr__(self, "z_h_m", e_m)
        elif not abs(self.z_h_m - e_m) <= CENTRAL_RTOL * e_m:
            raise DataError(
                f"HyperbolicCamera.z_h_m = {self.z_h_m!r} m makes a non-central camera: the "
                f"pinhole must sit at the outer focus, z_h = e = sqrt(a^2 + b^2) = {e_m!r} m"
            )
        if not -math.pi / 2.0 < self.min_elevation_rad < self.max_elevation_rad:
            raise DataError(
                f"HyperbolicCamera.min_elevation_rad = {self.min_elevation_rad!r} must lie in "
                f"(-pi/2, max_elevation_rad = {self.max_elevation_rad!r})"
            )

    # -- derived quantities -----------------------------------------------------------------

    @property
    def e_m(self) -> float:
        """Focal half-distance ``e = sqrt(a^2 + b^2)`` [m]; ``|F1 F2| = 2e``."""
        return math.hypot(self.a_m, self.b_m)

    @property
    def focal_px(self) -> float:
        """Focal length in pixels, ``f / pixel_size``."""
        return self.focal_length_m / self.pixel_size_m

    @property
    def asymptote_elevation_rad(self) -> float:
        """Elevation of the asymptotic cone, ``asin(a / e)``: no ray above it hits the mirror."""
        return math.asin(self.a_m / self.e_m)

    @property
    def max_elevation_rad(self) -> float:
        """Elevation (seen from ``F2``) of the mirror rim: the top of the field of view [rad]."""
        z_rim_m = self._rim_height_m()
        return math.atan2(z_rim_m, self.rim_radius_m)

    @property
    def outer_radius_px(self) -> float:
        """Pixel radius of the image of the mirror rim (outer edge of the mask)."""
        z_rim_m = self._rim_height_m()
        return self.focal_px * self.rim_radius_m / (z_rim_m + 2.0 * self.e_m)

    @property
    def inner_radius_px(self) -> float:
        """Pixel radius of the direction at ``min_elevation_rad`` (inner edge of the mask)."""
        return float(self.radius_px_of_elevation(np.array([self.min_elevation_rad]))[0])

    def _rim_height_m(self) -> float:
        """Height of the rim above ``F2``: ``z = a sqrt(1 + R^2 / b^2) - e`` [m]."""
        return self.a_m * math.sqrt(1.0 + (self.rim_radius_m / self.b_m) ** 2) - self.e_m

    def radius_px_of_elevation(self, elevation_rad: np.ndarray) -> np.ndarray:
        """Pixel distance from the principal point at which a given elevation images.

        Args:
            elevation_rad: (N,) elevations above the horizon seen from ``F2`` [rad].

        Returns:
            (N,) radii [px]; NaN above the asymptote (no mirror point).
        """
        elevation_rad = np.asarray(elevation_rad, dtype=float)
        rays_s = np.column_stack(
            [np.cos(elevation_rad), np.zeros_like(elevation_rad), np.sin(elevation_rad)]
        )
        pixels, _ = self.project(rays_s)
        return pixels[:, 0] - self.cu

    # -- geometry ---------------------------------------------------------------------------

    def mirror_point(self, rays_s: np.ndarray) -> np.ndarray:
        """Point of the mirror hit by the light travelling towards ``F2`` along ``-ray``.

        Substituting ``P = mu r`` (``|r| = 1``) into ``(z + e)^2/a^2 - rho^2/b^2 = 1`` gives
        ``(e^2 r_z^2 - a^2) mu^2 + 2 e b^2 r_z mu + b^4 = 0`` (times ``a^2 b^2``), whose
        discriminant is ``4 a^2 b^4``; the roots are ``mu = b^2 / (a - e r_z)`` and
        ``mu = -b^2 / (a + e r_z)``. The first lies on the sheet around ``F2``
        (``z + e = a (e - a r_z) / (a - e r_z) >= a``) and is in front of ``F2`` iff
        ``r_z < a / e``; the second lies on the virtual sheet around ``F1``.

        Args:
            rays_s: (N, 3) unit directions from ``F2`` in frame ``S``.

        Returns:
            (N, 3) mirror points in ``S`` [m]; NaN rows where ``r_z >= a / e``.
        """
        rays_s = as_points(rays_s, "rays_s")
        denominator = self.a_m - self.e_m * rays_s[:, 2]
        with np.errstate(divide="ignore", invalid="ignore"):
            mu_m = np.where(denominator > 0.0, self.b_m**2 / denominator, np.nan)
        return mu_m[:, None] * rays_s

    def project(self, points_c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Project points of frame ``S`` (origin ``F2``) through the mirror to pixels.

        Direction ``r = X / |X|`` -> mirror point ``P`` (``mirror_point``) -> pinhole image of
        ``P`` from ``F1 = (0, 0, -2e)``: ``[u, v] = [cu, cv] + (f / pixel) [P_x, P_y] /
        (P_z + 2e)`` (the inverse of thesis eqs. 4.18-4.20).

        Args:
            points_c: (N, 3) points in ``S`` [m].

        Returns:
            ``(pixels, valid)``: (N, 2) [px] (NaN above the asymptote or at ``F2``) and (N,)
            projectable and inside the image. The mirror rim is the mask's job (``in_mask``).
        """
        points_c = as_points(points_c)
        norm_m = np.linalg.norm(points_c, axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            rays_s = points_c / norm_m[:, None]
        P = self.mirror_point(rays_s)
        scale = self.focal_px / (P[:, 2] + 2.0 * self.e_m)
        pixels = np.column_stack([self.cu + scale * P[:, 0], self.cv + scale * P[:, 1]])
        valid = np.all(np.isfinite(pixels), axis=1) & self.in_image(pixels)
        return pixels, valid

    def unproject(self, pixels: np.ndarray) -> np.ndarray:
        """Rays of pixels, following thesis eqs. 4.18-4.20.

        Eq. 4.18: the image point ``I`` (metric, on the plane ``f`` above ``F1``) and ``F1``
        define the line ``F1 + alpha d``, ``d = [(u - cu) s, (v - cv) s, f]`` (``s`` the pixel
        size). Eq. 4.19 (with the line's origin ``F1`` at the thesis's origin, so
        ``x_v = y_v = z_v = 0``): ``A alpha^2 + B alpha + C = 0`` with
        ``A = d_z^2/a^2 - (d_x^2 + d_y^2)/b^2``, ``B = -2 d_z z_h / a^2``,
        ``C = z_h^2/a^2 - 1 = b^2/a^2``; ``B^2 - 4AC = 4 |d|^2 / a^2 > 0`` always.
        Root choice: inside the asymptotic cone (``A > 0``) both roots are positive - the
        line leaves the virtual sheet around ``F1`` (smaller root) before it reaches the
        mirror around ``F2`` - so the mirror is the larger root,
        ``alpha = (-B + sqrt(B^2 - 4AC)) / 2A`` (the thesis's sign). For ``A <= 0`` the
        line never reaches the mirror: NaN. Eq. 4.20: ``ray = (P - F2) / |P - F2|``; the
        rotation into the world by the robot pose is the rig's and the estimator's job.

        Args:
            pixels: (N, 2) ``[u, v]`` [px].

        Returns:
            (N, 3) unit rays in ``S``; NaN rows outside the asymptotic cone.
        """
        pixels = as_pixels(pixels)
        a2, b2, z_h = self.a_m**2, self.b_m**2, self.e_m
        d = np.column_stack(
            [
                (pixels[:, 0] - self.cu) * self.pixel_size_m,
                (pixels[:, 1] - self.cv) * self.pixel_size_m,
                np.full(len(pixels), self.focal_length_m),
            ]
        )
        A = d[:, 2] ** 2 / a2 - (d[:, 0] ** 2 + d[:, 1] ** 2) / b2
        B = -2.0 * d[:, 2] * z_h / a2
        discriminant = 4.0 * np.einsum("ij,ij->i", d, d) / a2  # = B^2 - 4AC, see docstring
        with np.errstate(divide="ignore", invalid="ignore"):
            alpha = np.where(A > 0.0, (-B + np.sqrt(discriminant)) / (2.0 * A), np.nan)
        P = alpha[:, None] * d
        P[:, 2] -= 2.0 * self.e_m  # F1 + alpha d, F1 = (0, 0, -2e) in S
        return P / np.linalg.norm(P, axis=1, keepdims=True)

    def project_jacobian(self, points_c: np.ndarray) -> np.ndarray:
        """Analytic ``d[u, v]/dX`` through the mirror, by the chain rule.

        ``r = X/|X|``: ``dr/dX = (I - r r^T) / |X|``; ``P = mu(r) r`` with
        ``dmu/dr_z = e mu^2 / b^2``: ``dP/dr = mu I + e mu^2 / b^2 r e_z^T``;
        ``[u, v] = c + k [P_x, P_y] / w`` with ``w = P_z + 2e``, ``k = f / pixel``:
        ``d[u, v]/dP = k [[1/w, 0, -P_x/w^2], [0, 1/w, -P_y/w^2]]``.

        Args:
            points_c: (N, 3) points in ``S`` [m].

        Returns:
            (N, 2, 3) [px/m]; NaN rows where the point is not projectable.
        """
        points_c = as_points(points_c)
        norm_m = np.linalg.norm(points_c, axis=1)
        with np.errstate(divide="ignore", invalid="ignore"):
            r = points_c / norm_m[:, None]
            dr_dX = (np.eye(3) - r[:, :, None] * r[:, None, :]) / norm_m[:, None, None]
        P = self.mirror_point(r)
        mu = np.linalg.norm(P, axis=1)
        dP_dr = mu[:, None, None] * np.eye(3)
        dP_dr[:, :, 2] += (self.e_m * mu**2 / self.b_m**2)[:, None] * r
        w = P[:, 2] + 2.0 * self.e_m
        k = self.focal_px
        dpix_dP = np.zeros((len(P), 2, 3))
        dpix_dP[:, 0, 0] = k / w
        dpix_dP[:, 1, 1] = k / w
        dpix_dP[:, 0, 2] = -k * P[:, 0] / w**2
        dpix_dP[:, 1, 2] = -k * P[:, 1] / w**2
        return dpix_dP @ dP_dr @ dr_dX

    # -- mask -------------------------------------------------------------------------------

    def in_mask(self, pixels: np.ndarray) -> np.ndarray:
        """(N,) True inside the image on the ring ``inner_radius_px <= R <= outer_radius_px``.

        The inner disc is the camera's own reflection, the outside of the ring the mirror
        support (thesis Fig. 5.15).
        """
        pixels = as_pixels(pixels)
        return self.in_image(pixels) & in_ring(
            pixels, self.cu, self.cv, self.inner_radius_px, self.outer_radius_px
        )
