"""The intrinsics each camera model exposes to the calibration, as one flat vector.

A parameterisation maps a vector ``q`` (what the least-squares solver moves) to a camera of
the package and back, names each entry, states bounds and finite-difference steps, and
converts a covariance of ``q`` into standard deviations of the camera's own fields. The
projection itself is always the camera model's ``project`` (each model exists once).

- unified (Mei): ``xi, gamma1, gamma2, cu, cv, k1, k2, p1, p2`` (skew 0, as Mei's toolbox).
- ocamcalib (Scaramuzza): ``a0, a2, ..., aN`` (``a1 = 0``, as the toolbox), ``center_row,
  center_col, c, e``, with ``d = 0``: ``f`` is radially symmetric, so a rotation of the sensor
  plane about the centre is absorbed by every board pose, and the 3-parameter affine of the
  toolbox has one gauge freedom (``A R(phi)`` rescaled to ``A[1, 1] = 1`` images the same);
  fixing ``d`` removes it (any ``A`` is a lower-triangular one times a rotation). The vector
  holds ``a_k R0^k`` [px] with ``R0`` a reference radius, so that every entry has the size of
  a pixel radius; ``std`` is reported for ``a_k``.
- hyperbolic (thesis 4.3): ``b_m, focal_length_m, cu, cv``. A central hyperbolic camera
  images like the unified one with ``xi(a/b)`` and ``gamma(f/pixel, a/b)`` only
  (:func:`~omnislam.camera.unified.hyperbolic_to_unified`): the mirror's scale and the pixel
  size are not observable from images, so ``a_m`` and ``pixel_size_m`` stay those of the
  template camera and ``b_m`` and ``focal_length_m`` carry the fitted shape and focal length.
"""

from __future__ import annotations

import dataclasses
from abc import ABC, abstractmethod
from dataclasses import dataclass

import numpy as np

from omnislam.camera.base import CameraModel
from omnislam.camera.hyperbolic import HyperbolicCamera
from omnislam.camera.ocamcalib import OCamCalibCamera
from omnislam.camera.unified import UnifiedCamera

#: relative central-difference step of the intrinsic Jacobian columns
FD_REL_STEP = 1e-6


class Parameterisation(ABC):
    """Vector <-> camera for one model (see the module docstring)."""

    names: tuple[str, ...]
    #: typical magnitude of each entry: the finite-difference step is FD_REL_STEP (|q| + typical)
    typical: np.ndarray

    @abstractmethod
    def vector(self, camera: CameraModel) -> np.ndarray:
        """(n,) the entries of ``camera``."""

    @abstractmethod
    def camera(self, q: np.ndarray) -> CameraModel:
        """The camera of the vector (raises DataError when the model rejects it)."""

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        """(n,) lower and upper bounds (default: none)."""
        n = len(self.names)
        return np.full(n, -np.inf), np.full(n, np.inf)

    def steps(self, q: np.ndarray) -> np.ndarray:
        """(n,) central-difference steps."""
        return FD_REL_STEP * (np.abs(q) + self.typical)

    def fields(self, q: np.ndarray, cov: np.ndarray) -> tuple[dict[str, float], dict[str, float]]:
        """Values and standard deviations of the named camera fields.

        Args:
            q: (n,) the vector.
            cov: (n, n) its covariance.

        Returns:
            ``(values, std)`` keyed by ``names``, in the units of the camera's fields.
        """
        std = np.sqrt(np.clip(np.diag(cov), 0.0, None))
        return (
            {name: float(v) for name, v in zip(self.names, q, strict=True)},
            {name: float(s) for name, s in zip(self.names, std, strict=True)},
        )


@dataclass(frozen=True)
class UnifiedParameters(Parameterisation):
    """Mei's model; ``template`` supplies the image size and mask radii."""

    template: UnifiedCamera
    names: tuple[str, ...] = ("xi", "gamma1", "gamma2", "cu", "cv", "k1", "k2", "p1", "p2")
    typical: np.ndarray = dataclasses.field(
        default_factory=lambda: np.array([1.0, 100, 100, 100, 100, 0.1, 0.1, 0.01, 0.01])
    )

    def vector(self, camera: CameraModel) -> np.ndarray:
        return np.array([getattr(camera, name) for name in self.names], dtype=float)

    def camera(self, q: np.ndarray) -> UnifiedCamera:
        return dataclasses.replace(
            self.template, **{name: float(v) for name, v in zip(self.names, q, strict=True)}
        )

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        lower, upper = super().bounds()
        lower[:3] = [0.0, 1e-3, 1e-3]
        return lower, upper


@dataclass(frozen=True)
class HyperbolicParameters(Parameterisation):
    """The hyperbolic-mirror camera; ``template`` fixes ``a_m``, ``pixel_size_m``, the mask."""

    template: HyperbolicCamera
    names: tuple[str, ...] = ("b_m", "focal_length_m", "cu", "cv")
    typical: np.ndarray = dataclasses.field(
        default_factory=lambda: np.array([0.01, 0.005, 100.0, 100.0])
    )

    def vector(self, camera: CameraModel) -> np.ndarray:
        return np.array([getattr(camera, name) for name in self.names], dtype=float)

    def camera(self, q: np.ndarray) -> HyperbolicCamera:
        return dataclasses.replace(
            self.template,
            z_h_m=None,
            **{name: float(v) for name, v in zip(self.names, q, strict=True)},
        )

    def bounds(self) -> tuple[np.ndarray, np.ndarray]:
        lower, upper = super().bounds()
        lower[:2] = 1e-6
        return lower, upper


@dataclass(frozen=True)
class OCamCalibParameters(Parameterisation):
    """Scaramuzza's model with a ``degree``-polynomial ``pol`` (``a1 = 0``).

    Attributes:
        template: supplies image size, ROI and crop.
        degree: degree of ``pol`` (the toolbox's default is 4).
        radius_px: reference radius ``R0`` of the scaled coefficients [px].
    """

    template: OCamCalibCamera
    degree: int = 4
    radius_px: float = 400.0
    names: tuple[str, ...] = ()
    typical: np.ndarray = dataclasses.field(default_factory=lambda: np.zeros(0))

    def __post_init__(self) -> None:
        powers = (0, *range(2, self.degree + 1))
        object.__setattr__(
            self,
            "names",
            (*(f"a{k}" for k in powers), "center_row", "center_col", "c", "e"),
        )
        typical = np.r_[np.full(len(powers), 100.0), 100.0, 100.0, 1.0, 0.01]
        object.__setattr__(self, "typical", typical)
        object.__setattr__(self, "_powers", np.array(powers))

    @property
    def powers(self) -> np.ndarray:
        """(degree,) the powers of rho that are free (0, 2, 3, ..., degree)."""
        return self._powers  # type: ignore[attr-defined]

    def vector(self, camera: CameraModel) -> np.ndarray:
        pol = np.zeros(self.degree + 1)
        pol[: len(camera.pol)] = camera.pol[: self.degree + 1]
        scaled = pol[self.powers] * self.radius_px ** self.powers.astype(float)
        return np.r_[scaled, camera.center_row, camera.center_col, camera.c, camera.e]

    def camera(self, q: np.ndarray) -> OCamCalibCamera:
        k = len(self.powers)
        pol = np.zeros(self.degree + 1)
        pol[self.powers] = q[:k] / self.radius_px ** self.powers.astype(float)
        return dataclasses.replace(
            self.template,
            pol=tuple(pol),
            center_row=float(q[k]),
            center_col=float(q[k + 1]),
            c=float(q[k + 2]),
            d=0.0,
            e=float(q[k + 3]),
            world2cam="exact",
        )

    def fields(self, q: np.ndarray, cov: np.ndarray) -> tuple[dict[str, float], dict[str, float]]:
        values, std = Parameterisation.fields(self, q, cov)
        for power in self.powers:
            scale = self.radius_px ** float(power)
            values[f"a{power}"] /= scale
            std[f"a{power}"] /= scale
        return values, std
