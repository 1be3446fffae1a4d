"""The one interface every camera model implements: project, unproject, mask, Jacobian, noise.

Conventions shared by all models:

- **Pixels** are ``(N, 2)`` arrays ``[u, v]`` with ``u`` the column and ``v`` the row, and
  ``(0, 0)`` at the *centre* of the top-left pixel; the image covers
  ``-0.5 <= u < width - 0.5`` and ``-0.5 <= v < height - 0.5``.
- **Points and rays** are ``(N, 3)`` arrays in the model's own camera frame (``*_c``); each
  model's docstring defines that frame. Rays are unit vectors from the single viewpoint.
- ``project`` returns ``valid`` = the point is mathematically projectable by the model **and**
  lands inside the image bounds. Points that cannot be projected at all get NaN pixels; points
  that project outside the image get their (extrapolated) pixel and ``valid`` False.
- The usable region (for catadioptric images: the ring between the camera's own reflection and
  the mirror rim, thesis Fig. 5.15) is a separate question, answered by ``in_mask``/``mask``.
- ``unproject`` returns the model's ray for every pixel where the model defines one (it does not
  check the image bounds or the mask) and NaN rows elsewhere.

Models are frozen, slotted dataclasses; ``to_dict``/``from_dict`` convert them to plain
dictionaries with a ``model`` key (YAML I/O lives in :mod:`omnislam.camera.io`).
"""

from __future__ import annotations

import dataclasses
import types
import typing
from abc import ABC, abstractmethod
from typing import Any, ClassVar, Self

import numpy as np

from omnislam.errors import DataError


def as_points(points: object, name: str = "points_c") -> np.ndarray:
    """Return ``points`` as a float ``(N, 3)`` array, raising DataError on another shape."""
    out = np.asarray(points, dtype=float)
    if out.ndim != 2 or out.shape[1] != 3:
        raise DataError(f"{name} must have shape (N, 3), got {out.shape}")
    return out


def as_pixels(pixels: object, name: str = "pixels") -> np.ndarray:
    """Return ``pixels`` as a float ``(N, 2)`` array, raising DataError on another shape."""
    out = np.asarray(pixels, dtype=float)
    if out.ndim != 2 or out.shape[1] != 2:
        raise DataError(f"{name} must have shape (N, 2), got {out.shape}")
    return out


def tangent_basis(rays: np.ndarray) -> np.ndarray:
    """Two orthonormal vectors spanning the plane perpendicular to each unit ray.

    Args:
        rays: (N, 3) unit vectors.

    Returns:
        (N, 3, 2) columns ``t1, t2`` with ``t1 x t2 = ray`` (a right-handed tangent frame).
    """
    rays = np.asarray(rays, dtype=float)
    # Helper axis: the world axis least aligned with the ray, so the cross product is well
    # conditioned everywhere (no singularity at the poles).
    helper = np.zeros_like(rays)
    helper[np.arange(len(rays)), np.argmin(np.abs(rays), axis=1)] = 1.0
    t1 = np.cross(helper, rays)
    t1 /= np.linalg.norm(t1, axis=1, keepdims=True)
    t2 = np.cross(rays, t1)
    return np.stack([t1, t2], axis=2)


def _check_field(cls_name: str, name: str, hint: object, value: object) -> object:
    """Convert a plain (YAML) value to the type annotated on a model field, or raise DataError."""
    origin = typing.get_origin(hint)
    if origin in (types.UnionType, typing.Union):
        options = typing.get_args(hint)
        if value is None and type(None) in options:
            return None
        hint = next(option for option in options if option is not type(None))
        origin = typing.get_origin(hint)
    where = f"{cls_name}.{name}"
    if hint is bool:
        if not isinstance(value, bool):
            raise DataError(f"{where} must be true or false, got {value!r}")
        return value
    if hint is int:
        if isinstance(value, bool) or not isinstance(value, int):
            raise DataError(f"{where} must be an integer, got {value!r}")
        return value
    if hint is float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise DataError(f"{where} must be a number, got {value!r}")
        return float(value)
    if hint is str:
        if not isinstance(value, str):
            raise DataError(f"{where} must be a string, got {value!r}")
        return value
    if origin is tuple:
        if not isinstance(value, (list, tuple)) or not all(
            isinstance(item, (int, float)) and not isinstance(item, bool) for item in value
        ):
            raise DataError(f"{where} must be a list of numbers, got {value!r}")
        return tuple(float(item) for item in value)
    raise DataError(f"{where}: unsupported field type {hint!r}")  # pragma: no cover


class CameraModel(ABC):
    """A central camera: pixels <-> unit rays from one viewpoint, with a usable-region mask.

    Subclasses are ``@dataclass(frozen=True, slots=True)`` with integer fields ``width`` and
    ``height`` [px] and a class constant ``MODEL`` (the ``model:`` key of their YAML form).
    """

    __slots__ = ()

    MODEL: ClassVar[str]
    width: int
    height: int

    # -- the model proper -------------------------------------------------------------------

    @abstractmethod
    def project(self, points_c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Project points (or directions) of the camera frame to pixels.

        Args:
            points_c: (N, 3) points in the model's camera frame [m] (any scale: only the
                direction from the viewpoint matters).

        Returns:
            ``(pixels, valid)``: (N, 2) ``[u, v]`` [px], NaN where the model cannot project
            the point; (N,) bool, projectable and inside the image bounds.
        """

    @abstractmethod
    def unproject(self, pixels: np.ndarray) -> np.ndarray:
        """Unit rays of pixels.

        Args:
            pixels: (N, 2) ``[u, v]`` [px].

        Returns:
            (N, 3) unit vectors in the model's camera frame; NaN rows where no ray exists.
        """

    @abstractmethod
    def project_jacobian(self, points_c: np.ndarray) -> np.ndarray:
        """Jacobian of ``project`` with respect to the point.

        Args:
            points_c: (N, 3) points in the camera frame [m].

        Returns:
            (N, 2, 3) ``d[u, v] / d[x, y, z]`` [px/m]; NaN where the point is not projectable.
        """

    # -- image region -----------------------------------------------------------------------

    def in_image(self, pixels: np.ndarray) -> np.ndarray:
        """(N,) True where ``pixels`` fall on the sensor (``-0.5 <= u < width - 0.5``, same v)."""
        pixels = as_pixels(pixels)
        u, v = pixels[:, 0], pixels[:, 1]
        with np.errstate(invalid="ignore"):
            return (u >= -0.5) & (u < self.width - 0.5) & (v >= -0.5) & (v < self.height - 0.5)

    def in_mask(self, pixels: np.ndarray) -> np.ndarray:
        """(N,) True where ``pixels`` lie in the usable image region (default: the whole image)."""
        return self.in_image(pixels)

    def mask(self) -> np.ndarray:
        """(height, width) bool: ``in_mask`` evaluated at every pixel centre."""
        v, u = np.mgrid[0 : self.height, 0 : self.width]
        pixels = np.column_stack([u.ravel(), v.ravel()]).astype(float)
        return self.in_mask(pixels).reshape(self.height, self.width)

    # -- noise ------------------------------------------------------------------------------

    def ray_covariance(self, pixels: np.ndarray, sigma_px: float = 1.0) -> np.ndarray:
        """Covariance of the unit ray produced by isotropic pixel noise, to first order.

        With ``r`` the ray of the pixel, ``T`` (3x2) an orthonormal basis of the plane
        perpendicular to ``r`` and ``M = J_project(r) T`` (2x2, pixels per radian of tangent
        rotation), a pixel perturbation ``dp`` moves the ray by ``T M^-1 dp``; hence
        ``Sigma_r = sigma_px^2 T (M^T M)^-1 T^T`` (rank 2, units rad^2).

        Args:
            pixels: (N, 2) ``[u, v]`` [px].
            sigma_px: isotropic pixel standard deviation [px].

        Returns:
            (N, 3, 3) covariances in the camera frame [rad^2]; NaN where no ray exists.
        """
        rays_c = self.unproject(pixels)
        tangent = tangent_basis(np.nan_to_num(rays_c, nan=1.0))
        info_rad = self._tangent_information(rays_c, tangent)
        with np.errstate(invalid="ignore"):
            cov_tangent = sigma_px**2 * np.linalg.inv(info_rad)
        cov = tangent @ cov_tangent @ np.swapaxes(tangent, 1, 2)
        cov[~np.all(np.isfinite(rays_c), axis=1)] = np.nan
        return cov

    def angular_sigma(self, pixels: np.ndarray, sigma_px: float = 1.0) -> np.ndarray:
        """Angular standard deviation of the ray produced by isotropic pixel noise.

        The ray error is a 2-D Gaussian on the tangent plane (see ``ray_covariance``); this
        returns the std along its **worst** direction, ``sigma_px / s_min(M)`` with ``s_min``
        the smaller singular value of ``M = J_project T``. The conservative choice makes an
        isotropic bearing model (``Bearings.sigmas_rad``) never over-confident. The
        catadioptric models are nearly conformal: on the default hyperbolic camera the two
        stds differ by 0.3 % at the inner mask radius and 7 % at the rim.

        Args:
            pixels: (N, 2) ``[u, v]`` [px].
            sigma_px: isotropic pixel standard deviation [px].

        Returns:
            (N,) angular std [rad]; NaN where no ray exists.
        """
        rays_c = self.unproject(pixels)
        tangent = tangent_basis(np.nan_to_num(rays_c, nan=1.0))
        info_rad = self._tangent_information(rays_c, tangent)
        smallest = np.linalg.eigvalsh(np.nan_to_num(info_rad))[:, 0]
        with np.errstate(divide="ignore", invalid="ignore"):
            sigma_rad = sigma_px / np.sqrt(smallest)
        sigma_rad[~np.all(np.isfinite(info_rad), axis=(1, 2))] = np.nan
        return sigma_rad

    def _tangent_information(self, rays_c: np.ndarray, tangent: np.ndarray) -> np.ndarray:
        """(N, 2, 2) ``M^T M`` with ``M = J_project(ray) T`` [px^2/rad^2]."""
        M = self.project_jacobian(np.nan_to_num(rays_c, nan=1.0)) @ tangent
        M[~np.all(np.isfinite(rays_c), axis=1)] = np.nan
        return np.swapaxes(M, 1, 2) @ M

    # -- serialisation ----------------------------------------------------------------------

    def to_dict(self) -> dict[str, Any]:
        """Plain-Python form (``model`` key first, then every field; tuples become lists)."""
        out: dict[str, Any] = {"model": self.MODEL}
        for item in dataclasses.fields(self):  # type: ignore[arg-type]
            value = getattr(self, item.name)
            out[item.name] = list(value) if isinstance(value, tuple) else value
        return out

    @classmethod
    def from_dict(cls, d: dict[str, Any]) -> Self:
        """Build the model from ``to_dict``'s form; fields with defaults may be omitted.

        Raises:
            DataError: wrong ``model`` key, unknown or missing keys, values of the wrong type,
                or parameters the model rejects.
        """
        if not isinstance(d, dict):
            raise DataError(f"a {cls.MODEL} camera must be a mapping, got {type(d).__name__}")
        if d.get("model", cls.MODEL) != cls.MODEL:
            raise DataError(f"model is {d.get('model')!r}, expected {cls.MODEL!r}")
        fields = {item.name: item for item in dataclasses.fields(cls)}  # type: ignore[arg-type]
        unknown = sorted(set(d) - set(fields) - {"model"})
        if unknown:
            raise DataError(f"unknown key(s) for model {cls.MODEL!r}: {', '.join(unknown)}")
        hints = typing.get_type_hints(cls)
        kwargs = {
            name: _check_field(cls.__name__, name, hints[name], value)
            for name, value in d.items()
            if name != "model"
        }
        missing = sorted(
            name
            for name, item in fields.items()
            if name not in d
            and item.default is dataclasses.MISSING
            and item.default_factory is dataclasses.MISSING
        )
        if missing:
            raise DataError(f"missing key(s) for model {cls.MODEL!r}: {', '.join(missing)}")
        try:
            return cls(**kwargs)
        except (TypeError, ValueError) as exc:  # pragma: no cover - guarded by checks above
            raise DataError(f"invalid {cls.MODEL} camera: {exc}") from exc


def check_image_size(width: int, height: int, name: str) -> None:
    """Raise DataError unless width and height are positive integers."""
    for label, value in (("width", width), ("height", height)):
        if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value <= 0:
            raise DataError(f"{name}.{label} must be a positive integer, got {value!r}")


def check_principal_point(u: float, v: float, width: int, height: int, name: str) -> None:
    """Raise DataError unless the principal point ``(u, v)`` [px] lies inside the image.

    Pixel-centre convention (see the module docstring): inside means ``-0.5 <= u < width - 0.5``
    and the same for ``v``. A centre outside the image is a calibration for another image size
    (or a swapped row/column), and every ray would miss the mirror.
    """
    if not (np.isfinite(u) and np.isfinite(v)):
        raise DataError(f"{name}: principal point ({u!r}, {v!r}) is not finite")
    if not (-0.5 <= u < width - 0.5 and -0.5 <= v < height - 0.5):
        raise DataError(
            f"{name}: principal point (u={u!r}, v={v!r}) px is outside the {width}x{height} image"
        )


def check_positive(value: float, label: str) -> None:
    """Raise DataError unless ``value`` is a finite positive number."""
    if not np.isfinite(value) or value <= 0:
        raise DataError(f"{label} must be positive and finite, got {value!r}")


def in_ring(
    pixels: np.ndarray, cu: float, cv: float, inner_px: float, outer_px: float | None
) -> np.ndarray:
    """(N,) True where ``inner_px <= |pixel - (cu, cv)| <= outer_px`` (no outer limit if None)."""
    radius_px = np.hypot(pixels[:, 0] - cu, pixels[:, 1] - cv)
    with np.errstate(invalid="ignore"):
        inside = radius_px >= inner_px
        if outer_px is not None:
            inside &= radius_px <= outer_px
    return inside
