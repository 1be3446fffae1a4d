"""A camera mounted on the robot: the model plus the camera frame expressed in the robot frame."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from omnislam.camera.base import CameraModel, as_pixels, as_points
from omnislam.camera.registry import camera_from_dict
from omnislam.errors import DataError

#: tolerance on the orthogonality of rTc's 3x3 block
ORTHOGONALITY_TOL = 1e-9


@dataclass(frozen=True, slots=True, eq=False)
class CameraRig:
    """A camera and its mounting on the robot.

    Attributes:
        camera: the camera model (its own frame ``c``).
        rTc: (4, 4) the camera frame expressed in the robot frame (x forward, y left, z up):
            ``p_r = rTc @ [p_c, 1]``. The 3x3 block must be orthogonal; it may be a
            **reflection** (det -1) because a model can describe a catadioptric image in the
            mirror image of the physical frame (the unified model with positive gamma, see
            ``hyperbolic_to_unified``; OCamCalib's (row, column, z) frame). Read-only.
    """

    camera: CameraModel
    rTc: np.ndarray

    def __post_init__(self) -> None:
        if not isinstance(self.camera, CameraModel):
            raise DataError(f"CameraRig.camera must be a CameraModel, got {type(self.camera)}")
        rTc = np.array(self.rTc, dtype=float, copy=True)
        if rTc.shape != (4, 4) or not np.all(np.isfinite(rTc)):
            raise DataError(f"CameraRig.rTc must be a finite (4, 4) matrix, got {rTc.shape}")
        if not np.allclose(rTc[3], [0.0, 0.0, 0.0, 1.0], atol=0.0):
            raise DataError("CameraRig.rTc last row must be [0, 0, 0, 1]")
        R = rTc[:3, :3]
        if not np.allclose(R @ R.T, np.eye(3), atol=ORTHOGONALITY_TOL):
            raise DataError("CameraRig.rTc rotation block must be orthogonal")
        rTc.setflags(write=False)
        object.__setattr__(self, "rTc", rTc)

    @property
    def viewpoint_r(self) -> np.ndarray:
        """(3,) the camera's single viewpoint in the robot frame [m]."""
        return self.rTc[:3, 3].copy()

    @property
    def is_reflection(self) -> bool:
        """True when ``rTc`` mirrors (its 3x3 block has determinant -1)."""
        return bool(np.linalg.det(self.rTc[:3, :3]) < 0.0)

    def project_r(self, points_r: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Project robot-frame points to pixels.

        Args:
            points_r: (N, 3) points in the robot frame [m].

        Returns:
            ``(pixels, valid)`` of ``camera.project`` applied to ``cTr p_r``.
        """
        points_r = as_points(points_r, "points_r")
        R, t = self.rTc[:3, :3], self.rTc[:3, 3]
        points_c = (points_r - t) @ R  # R^T (p_r - t), R orthogonal
        return self.camera.project(points_c)

    def rays_r(self, pixels: np.ndarray) -> np.ndarray:
        """Unit rays of pixels in the robot frame (from ``viewpoint_r``).

        Args:
            pixels: (N, 2) ``[u, v]`` [px].

        Returns:
            (N, 3) unit vectors in the robot frame; NaN rows where the camera has no ray.
        """
        return self.camera.unproject(as_pixels(pixels)) @ self.rTc[:3, :3].T

    def to_dict(self) -> dict[str, Any]:
        """Plain-Python form: ``{"camera": {...}, "rTc": 4x4 nested list}``."""
        return {"camera": self.camera.to_dict(), "rTc": self.rTc.tolist()}

    @classmethod
    def from_dict(cls, d: Any) -> CameraRig:
        """Inverse of ``to_dict``.

        Raises:
            DataError: missing or unknown keys, a bad camera, or a bad ``rTc``.
        """
        if not isinstance(d, dict):
            raise DataError(f"a camera rig must be a mapping, got {type(d).__name__}")
        missing = sorted({"camera", "rTc"} - set(d))
        if missing:
            raise DataError(f"missing key(s) for a camera rig: {', '.join(missing)}")
        unknown = sorted(set(d) - {"camera", "rTc"})
        if unknown:
            raise DataError(f"unknown key(s) for a camera rig: {', '.join(unknown)}")
        try:
            rTc = np.array(d["rTc"], dtype=float)
        except (TypeError, ValueError) as exc:
            raise DataError(f"rTc must be a 4x4 list of numbers: {exc}") from exc
        return cls(camera=camera_from_dict(d["camera"]), rTc=rTc)

    def __eq__(self, other: object) -> bool:
        """Same camera and bit-identical ``rTc``."""
        if not isinstance(other, CameraRig):
            return NotImplemented
        return self.camera == other.camera and np.array_equal(self.rTc, other.rTc)
