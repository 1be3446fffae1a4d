"""Perspective (pinhole) camera with optional radial-tangential distortion.

The camera of the vertical-lines UKF (Barra & Costa). Frame: ``z`` along the optical axis
(forward), ``x`` along image columns (right), ``y`` along rows (down). A point projects to
``m = [X/Z, Y/Z]``, ``m_d = D(m)`` (:mod:`omnislam.camera.distortion`),
``u = fx m_x + skew m_y + cu``, ``v = fy m_y + cv``.
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
)
from omnislam.camera.distortion import RadialTangential


@dataclass(frozen=True, slots=True)
class PinholeCamera(CameraModel):
    """Pinhole camera; the whole image is usable (``in_mask`` = ``in_image``).

    Attributes:
        fx: focal length along u [px].
        fy: focal length along v [px].
        cu: principal point column [px].
        cv: principal point row [px].
        width: image width [px].
        height: image height [px].
        skew: ``K[0, 1]`` [px].
        k1, k2: radial distortion on the normalised plane (dimensionless).
        p1, p2: tangential distortion on the normalised plane (dimensionless).
    """

    MODEL: ClassVar[str] = "pinhole"

    fx: float
    fy: float
    cu: float
    cv: float
    width: int
    height: int
    skew: float = 0.0
    k1: float = 0.0
    k2: float = 0.0
    p1: float = 0.0
    p2: float = 0.0

    def __post_init__(self) -> None:
        check_image_size(self.width, self.height, "PinholeCamera")
        check_principal_point(
            float(self.cu), float(self.cv), self.width, self.height, "PinholeCamera"
        )
        check_positive(self.fx, "PinholeCamera.fx")
        check_positive(self.fy, "PinholeCamera.fy")

    @property
    def distortion(self) -> RadialTangential:
        """The distortion coefficients as one object."""
        return RadialTangential(self.k1, self.k2, self.p1, self.p2)

    @property
    def K(self) -> np.ndarray:
        """(3, 3) camera matrix [px]."""
        return np.array([[self.fx, self.skew, self.cu], [0.0, self.fy, self.cv], [0.0, 0.0, 1.0]])

    def project(self, points_c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Project points to pixels.

        Args:
            points_c: (N, 3) points in the camera frame [m].

        Returns:
            ``(pixels, valid)``: (N, 2) [px], NaN for points not in front of the camera
            (``Z <= 0``) or past the turning point of the radial distortion; (N,) projectable
            and inside the image.
        """
        points_c = as_points(points_c)
        with np.errstate(divide="ignore", invalid="ignore"):
            m_u = points_c[:, :2] / points_c[:, 2:]
        m_u[~(points_c[:, 2] > 0.0)] = np.nan
        distortion = self.distortion
        m_d, _ = distortion.distort(m_u)
        m_d[~distortion.is_monotonic(m_u)] = np.nan
        pixels = np.column_stack(
            [
                self.fx * m_d[:, 0] + self.skew * m_d[:, 1] + self.cu,
                self.fy * m_d[:, 1] + self.cv,
            ]
        )
        valid = np.all(np.isfinite(pixels), axis=1) & self.in_image(pixels)
        return pixels, valid

    def unproject(self, pixels: np.ndarray) -> np.ndarray:
        """Rays of pixels (Newton undistortion when distorted).

        Args:
            pixels: (N, 2) ``[u, v]`` [px].

        Returns:
            (N, 3) unit rays with ``z > 0``; NaN rows where the undistortion fails.
        """
        pixels = as_pixels(pixels)
        m_y = (pixels[:, 1] - self.cv) / self.fy
        m_x = (pixels[:, 0] - self.cu - self.skew * m_y) / self.fx
        m_u = self.distortion.undistort(np.column_stack([m_x, m_y]))
        rays_c = np.column_stack([m_u, np.ones(len(m_u))])
        return rays_c / np.linalg.norm(rays_c, axis=1, keepdims=True)

    def project_jacobian(self, points_c: np.ndarray) -> np.ndarray:
        """Analytic ``d[u, v]/dX = K_2x2 @ dD/dm @ dm/dX``, ``dm/dX = [[1/Z, 0, -X/Z^2],
        [0, 1/Z, -Y/Z^2]]``.

        Args:
            points_c: (N, 3) points in the camera frame [m].

        Returns:
            (N, 2, 3) [px/m]; NaN where ``Z <= 0``.
        """
        points_c = as_points(points_c)
        with np.errstate(divide="ignore", invalid="ignore"):
            inv_z = np.where(points_c[:, 2] > 0.0, 1.0 / points_c[:, 2], np.nan)
        m_u = points_c[:, :2] * inv_z[:, None]
        dm_dX = np.zeros((len(points_c), 2, 3))
        dm_dX[:, 0, 0] = inv_z
        dm_dX[:, 1, 1] = inv_z
        dm_dX[:, :, 2] = -m_u * inv_z[:, None]
        _, dD_dm = self.distortion.distort(m_u)
        K = np.array([[self.fx, self.skew], [0.0, self.fy]])
        return K @ dD_dm @ dm_dX
