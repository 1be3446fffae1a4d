"""Scaramuzza's OCamCalib polynomial omnidirectional model, and its ``calib_results.txt``.

Model (Scaramuzza, Martinelli & Siegwart 2006; the toolbox's ``ocam_functions.c``). A pixel at
(row, column) is first corrected by the affine ``A = [[c, d], [e, 1]]`` about the centre
``(xc, yc)`` = (``center_row``, ``center_col``):

    [row - xc, col - yc] = A [x', y'],                      rho = |[x', y']|

and sees the direction ``(x', y', f(rho))``, ``f(rho) = pol[0] + pol[1] rho + ...``
(``cam2world``). The toolbox projects with a fitted inverse polynomial ``rho = invpol(theta)``,
``theta = atan(z / |[x, y]|)`` (``world2cam``); the exact inverse is the smallest positive
real root of ``f(rho) - rho z / |[x, y]| = 0`` (the MATLAB toolbox's ``omni3d2pixel``).

Frame (OCamCalib's own): ``x`` along increasing image **rows**, ``y`` along increasing
**columns**, ``z`` completing it with the sign fixed by ``pol``: with ``pol[0] < 0`` (as
calibrations produce) the image centre looks along ``-z``, i.e. ``z`` points from the
camera's own reflection towards the mirror, like ``z`` of the hyperbolic model's frame ``S``.
Because rows come first, ``(x, y)`` are swapped relative to ``S`` (columns = ``x``): the two
frames differ by an improper orthogonal matrix ``[[0, 1, 0], [1, 0, 0], [0, 0, 1]]``, to be
absorbed in a rig's ``rTc``. Our pixels stay ``[u, v] = [column, row]``.

Crop. Some calibrations (e.g. the pyomniunwarp office example) apply to an image cropped by
``crop_left_px`` columns on the left and ``crop_right_px`` on the right; ``width`` is the
cropped width and every pixel of this model is a pixel of the cropped image. Use
``cropped_from_original`` / ``original_from_cropped`` to convert.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import ClassVar

import numpy as np

from omnislam.camera.base import (
    CameraModel,
    as_pixels,
    as_points,
    check_image_size,
    check_principal_point,
    in_ring,
)
from omnislam.errors import DataError

#: projection methods: the toolbox's fitted inverse polynomial, or the exact root solve
WORLD2CAM_METHODS = ("exact", "invpol")
#: relative step of the central-difference Jacobian
JACOBIAN_REL_STEP = 1e-6
#: |imag| / (1 + |real|) below which a polynomial root counts as real
REAL_ROOT_TOL = 1e-9


def _polyval(coefficients: tuple[float, ...], x: np.ndarray) -> np.ndarray:
    """Evaluate ``sum_k coefficients[k] x^k`` (ascending powers, Horner)."""
    out = np.full_like(x, coefficients[-1], dtype=float)
    for coefficient in coefficients[-2::-1]:
        out = out * x + coefficient
    return out


@dataclass(frozen=True, slots=True)
class OCamCalibCamera(CameraModel):
    """OCamCalib polynomial camera (frame and conventions in the module docstring).

    Attributes:
        pol: ``ss``, cam2world polynomial coefficients in ascending powers of rho [px^(1-k)].
        invpol: world2cam polynomial coefficients in ascending powers of theta [px / rad^k].
        center_row: distortion centre row ``xc`` [px] (0-based, C convention).
        center_col: distortion centre column ``yc`` [px].
        c, d, e: affine parameters (dimensionless).
        width: (cropped) image width [px].
        height: image height [px].
        roi_min_radius_px: inner radius of the usable ring about the centre [px].
        roi_max_radius_px: outer radius of the usable ring [px]; None = no limit.
        crop_left_px: columns cropped from the left of the original image [px].
        crop_right_px: columns cropped from the right of the original image [px].
        world2cam: ``"exact"`` (root solve; exact inverse of ``unproject``, the default) or
            ``"invpol"`` (the toolbox's fitted polynomial, bit-compatible with its C code).
    """

    MODEL: ClassVar[str] = "ocamcalib"

    pol: tuple[float, ...]
    invpol: tuple[float, ...]
    center_row: float
    center_col: float
    c: float
    d: float
    e: float
    width: int
    height: int
    roi_min_radius_px: float = 0.0
    roi_max_radius_px: float | None = None
    crop_left_px: int = 0
    crop_right_px: int = 0
    world2cam: str = "exact"

    def __post_init__(self) -> None:
        check_image_size(self.width, self.height, "OCamCalibCamera")
        check_principal_point(
            float(self.center_col),
            float(self.center_row),
            self.width,
            self.height,
            "OCamCalibCamera",
        )
        pol = tuple(float(x) for x in self.pol)
        invpol = tuple(float(x) for x in self.invpol)
        object.__setattr__(self, "pol", pol)
        object.__setattr__(self, "invpol", invpol)
        if len(pol) < 2 or pol[-1] == 0.0 or pol[0] == 0.0:
            raise DataError(
                "OCamCalibCamera.pol needs >= 2 coefficients, a non-zero constant and a "
                f"non-zero leading coefficient, got {pol!r}"
            )
        if len(invpol) < 1:
            raise DataError("OCamCalibCamera.invpol must not be empty")
        if not np.all(np.isfinite(pol + invpol)):
            raise DataError("OCamCalibCamera polynomials must be finite")
        if abs(self.c - self.d * self.e) < 1e-12:
            raise DataError(
                f"OCamCalibCamera affine matrix [[c, d], [e, 1]] is singular: "
                f"c={self.c!r}, d={self.d!r}, e={self.e!r}"
            )
        if self.world2cam not in WORLD2CAM_METHODS:
            raise DataError(
                f"OCamCalibCamera.world2cam must be one of {WORLD2CAM_METHODS}, "
                f"got {self.world2cam!r}"
            )
        if self.roi_min_radius_px < 0.0 or (
            self.roi_max_radius_px is not None and self.roi_max_radius_px <= self.roi_min_radius_px
        ):
            raise DataError(
                "OCamCalibCamera ROI radii must satisfy 0 <= min < max, got "
                f"min={self.roi_min_radius_px!r}, max={self.roi_max_radius_px!r}"
            )
        if self.crop_left_px < 0 or self.crop_right_px < 0:
            raise DataError("OCamCalibCamera crop widths must be >= 0")

    # -- crop -------------------------------------------------------------------------------

    @property
    def original_width(self) -> int:
        """Width of the uncropped image [px]."""
        return self.width + self.crop_left_px + self.crop_right_px

    def cropped_from_original(self, pixels: np.ndarray) -> np.ndarray:
        """(N, 2) pixels of the original image -> pixels of the calibrated (cropped) image."""
        out = as_pixels(pixels).copy()
        out[:, 0] -= self.crop_left_px
        return out

    def original_from_cropped(self, pixels: np.ndarray) -> np.ndarray:
        """(N, 2) pixels of the calibrated (cropped) image -> pixels of the original image."""
        out = as_pixels(pixels).copy()
        out[:, 0] += self.crop_left_px
        return out

    # -- model ------------------------------------------------------------------------------

    def unproject(self, pixels: np.ndarray) -> np.ndarray:
        """``cam2world`` of the toolbox, vectorised.

        Args:
            pixels: (N, 2) ``[u, v]`` = [column, row] of the cropped image [px].

        Returns:
            (N, 3) unit rays in OCamCalib's frame (x = rows, y = columns).
        """
        pixels = as_pixels(pixels)
        d_row = pixels[:, 1] - self.center_row
        d_col = pixels[:, 0] - self.center_col
        inv_det = 1.0 / (self.c - self.d * self.e)
        x = inv_det * (d_row - self.d * d_col)
        y = inv_det * (-self.e * d_row + self.c * d_col)
        z = _polyval(self.pol, np.hypot(x, y))
        rays_c = np.column_stack([x, y, z])
        return rays_c / np.linalg.norm(rays_c, axis=1, keepdims=True)

    def project(self, points_c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``world2cam``: by ``invpol`` or by the exact root solve (field ``world2cam``).

        Args:
            points_c: (N, 3) points in OCamCalib's frame [m].

        Returns:
            ``(pixels, valid)``: (N, 2) ``[u, v]`` [px], NaN where the exact solve finds no
            positive root; (N,) projectable and inside the image.
        """
        if self.world2cam == "invpol":
            return self.project_invpol(points_c)
        return self.project_exact(points_c)

    def project_invpol(self, points_c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The toolbox's ``world2cam``: ``rho = invpol(atan(z / |[x, y]|))``.

        Args:
            points_c: (N, 3) points in OCamCalib's frame [m].

        Returns:
            ``(pixels, valid)`` as ``project``. On the axis (``x = y = 0``) the point images
            at the centre if it lies on the side the centre sees (``sign z = sign pol[0]``).
        """
        points_c = as_points(points_c)
        norm_xy = np.hypot(points_c[:, 0], points_c[:, 1])
        with np.errstate(divide="ignore", invalid="ignore"):
            theta = np.arctan(points_c[:, 2] / norm_xy)
            rho = _polyval(self.invpol, theta)
            radial = rho / norm_xy
        return self._to_pixels(points_c, radial, norm_xy)

    def project_exact(self, points_c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Exact inverse of ``unproject``: the smallest positive real root of
        ``pol(rho) - rho z / |[x, y]| = 0`` (companion-matrix eigenvalues, then two Newton
        steps to polish), as the MATLAB toolbox's ``omni3d2pixel``.

        Args:
            points_c: (N, 3) points in OCamCalib's frame [m].

        Returns:
            ``(pixels, valid)`` as ``project``.
        """
        points_c = as_points(points_c)
        norm_xy = np.hypot(points_c[:, 0], points_c[:, 1])
        with np.errstate(divide="ignore", invalid="ignore"):
            slope = points_c[:, 2] / norm_xy
        rho = np.full(len(points_c), np.nan)
        finite = np.isfinite(slope)
        rho[finite] = self._smallest_positive_root(slope[finite])
        with np.errstate(divide="ignore", invalid="ignore"):
            radial = rho / norm_xy
        return self._to_pixels(points_c, radial, norm_xy)

    def _smallest_positive_root(self, slope: np.ndarray) -> np.ndarray:
        """Per slope ``s``: smallest positive real root of ``pol(rho) - s rho`` (NaN if none)."""
        degree = len(self.pol) - 1
        coefficients = np.tile(np.asarray(self.pol, dtype=float), (len(slope), 1))
        coefficients[:, 1] -= slope
        # Companion matrix of the monic polynomial (ascending powers a_0 .. a_n, a_n != 0).
        companion = np.zeros((len(slope), degree, degree))
        companion[:, 1:, :-1] = np.eye(degree - 1)
        companion[:, :, -1] = -coefficients[:, :-1] / coefficients[:, -1:]
        roots = np.linalg.eigvals(companion) if degree > 0 else np.zeros((len(slope), 0))
        real = np.abs(roots.imag) <= REAL_ROOT_TOL * (1.0 + np.abs(roots.real))
        candidates = np.where(real & (roots.real > 0.0), roots.real, np.inf)
        rho = candidates.min(axis=1) if degree > 0 else np.full(len(slope), np.inf)
        rho[~np.isfinite(rho)] = np.nan
        derivative = tuple(k * a for k, a in enumerate(self.pol))[1:]
        for _ in range(2):
            value = _polyval(self.pol, rho) - slope * rho
            gradient = _polyval(derivative, rho) - slope
            with np.errstate(divide="ignore", invalid="ignore"):
                step = np.where(gradient != 0.0, value / gradient, 0.0)
            rho = rho - step
        return rho

    def _to_pixels(
        self, points_c: np.ndarray, radial: np.ndarray, norm_xy: np.ndarray
    ) -> tuple[np.ndarray, np.ndarray]:
        """Sensor-plane ``[x', y'] = radial [x, y]`` -> affine -> ``[u, v]``; handles the axis."""
        x = points_c[:, 0] * radial
        y = points_c[:, 1] * radial
        on_axis = norm_xy == 0.0
        seen = np.sign(points_c[:, 2]) == np.sign(self.pol[0])
        x[on_axis] = np.where(seen[on_axis], 0.0, np.nan)
        y[on_axis] = np.where(seen[on_axis], 0.0, np.nan)
        row = x * self.c + y * self.d + self.center_row
        col = x * self.e + y + self.center_col
        pixels = np.column_stack([col, row])
        valid = np.all(np.isfinite(pixels), axis=1) & self.in_image(pixels)
        return pixels, valid

    def project_jacobian(self, points_c: np.ndarray) -> np.ndarray:
        """Central-difference ``d[u, v]/dX`` of ``project`` (step ``1e-6 |X|`` per axis).

        Args:
            points_c: (N, 3) points in OCamCalib's frame [m].

        Returns:
            (N, 2, 3) [px/m]; NaN where not projectable.
        """
        points_c = as_points(points_c)
        step = JACOBIAN_REL_STEP * np.linalg.norm(points_c, axis=1)
        J = np.empty((len(points_c), 2, 3))
        for axis in range(3):
            offset = np.zeros_like(points_c)
            offset[:, axis] = step
            plus, _ = self.project(points_c + offset)
            minus, _ = self.project(points_c - offset)
            J[:, :, axis] = (plus - minus) / (2.0 * step[:, None])
        return J

    def in_mask(self, pixels: np.ndarray) -> np.ndarray:
        """(N,) True inside the image on the ROI ring ``min <= R <= max`` about the centre."""
        pixels = as_pixels(pixels)
        return self.in_image(pixels) & in_ring(
            pixels, self.center_col, self.center_row, self.roi_min_radius_px, self.roi_max_radius_px
        )


# -- calib_results.txt ------------------------------------------------------------------------

_SECTIONS = (
    ("pol", None),
    ("invpol", None),
    ("center", 2),
    ("affine", 3),
    ("image size", 2),
    ("ROI max min radius", 2),
    ("left right cropped pixel", 2),
)
_REQUIRED_SECTIONS = 5


def read_ocamcalib(path: str | Path, world2cam: str = "exact") -> OCamCalibCamera:
    """Read a ``calib_results.txt`` as written by the OCamCalib toolbox.

    Data lines (blank lines and ``#`` comments skipped) in order: ``pol`` (count, then that
    many coefficients), ``invpol`` (same), centre ``row column``, affine ``c d e``, image
    ``height width``, and optionally ROI ``max min`` radius and ``left right`` cropped columns
    (written by pyomniunwarp).

    Args:
        path: the file.
        world2cam: projection method of the returned camera (``"exact"`` or ``"invpol"``).

    Returns:
        The camera; ``width`` is the cropped width as written in the file.

    Raises:
        DataError: naming the file and line when a line is malformed, a section is missing,
            or the parameters are inconsistent.
    """
    path = Path(path)
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as exc:
        raise DataError(f"cannot read OCamCalib file: {exc}", path) from exc
    data: list[tuple[int, list[float]]] = []
    for number, line in enumerate(text.splitlines(), start=1):
        stripped = line.strip()
        if not stripped or stripped.startswith("#"):
            continue
        try:
            data.append((number, [float(token) for token in stripped.split()]))
        except ValueError:
            raise DataError(f"line {number}: expected numbers, got {stripped!r}", path) from None
    if len(data) < _REQUIRED_SECTIONS:
        missing = ", ".join(name for name, _ in _SECTIONS[len(data) : _REQUIRED_SECTIONS])
        raise DataError(f"missing section(s): {missing}", path)
    if len(data) > len(_SECTIONS):
        raise DataError(f"line {data[len(_SECTIONS)][0]}: unexpected extra data", path)
    values: dict[str, list[float]] = {}
    for (name, count), (number, numbers) in zip(_SECTIONS, data, strict=False):
        if count is None:  # polynomial: "n a_0 ... a_(n-1)"
            n = numbers[0]
            if n != int(n) or n < 1 or len(numbers) != int(n) + 1:
                raise DataError(
                    f"line {number}: {name} must be a count n followed by n coefficients, "
                    f"got {len(numbers) - 1} number(s) after {numbers[0]!r}",
                    path,
                )
            values[name] = numbers[1:]
        elif len(numbers) != count:
            raise DataError(
                f"line {number}: {name} needs {count} numbers, got {len(numbers)}", path
            )
        else:
            values[name] = numbers
    height, width = values["image size"]
    for number, label, value in ((data[4][0], "height", height), (data[4][0], "width", width)):
        if value != int(value) or value <= 0:
            raise DataError(f"line {number}: image {label} must be a positive integer", path)
    roi_max, roi_min = values.get("ROI max min radius", [None, 0.0])
    crop_left, crop_right = values.get("left right cropped pixel", [0.0, 0.0])
    if crop_left != int(crop_left) or crop_right != int(crop_right):
        raise DataError(f"line {data[-1][0]}: cropped pixels must be integers", path)
    try:
        return OCamCalibCamera(
            pol=tuple(values["pol"]),
            invpol=tuple(values["invpol"]),
            center_row=values["center"][0],
            center_col=values["center"][1],
            c=values["affine"][0],
            d=values["affine"][1],
            e=values["affine"][2],
            width=int(width),
            height=int(height),
            roi_min_radius_px=roi_min,
            roi_max_radius_px=roi_max,
            crop_left_px=int(crop_left),
            crop_right_px=int(crop_right),
            world2cam=world2cam,
        )
    except DataError as exc:
        raise DataError(str(exc), path) from exc


def write_ocamcalib(camera: OCamCalibCamera, path: str | Path) -> None:
    """Write ``camera`` in the toolbox's ``calib_results.txt`` layout (full float precision).

    The ROI and crop sections are written when the camera has them (ROI max radius set or a
    non-zero crop); ``read_ocamcalib`` reads the file back to an equal camera.
    """

    def numbers(values: tuple[float, ...] | list[float]) -> str:
        return " ".join(repr(float(v)) for v in values)

    lines = [
        "#polynomial coefficients for the DIRECT mapping function (ocam_model.ss in MATLAB). "
        "These are used by cam2world",
        "",
        f"{len(camera.pol)} {numbers(camera.pol)} ",
        "",
        "#polynomial coefficients for the inverse mapping function (ocam_model.invpol in "
        "MATLAB). These are used by world2cam",
        "",
        f"{len(camera.invpol)} {numbers(camera.invpol)} ",
        "",
        '#center: "row" and "column", starting from 0 (C convention)',
        "",
        numbers([camera.center_row, camera.center_col]),
        "",
        '#affine parameters "c", "d", "e"',
        "",
        numbers([camera.c, camera.d, camera.e]),
        "",
        '#image size: "height" and "width"',
        "",
        f"{camera.height} {camera.width}",
    ]
    has_crop = camera.crop_left_px or camera.crop_right_px
    if camera.roi_max_radius_px is not None or has_crop:
        if camera.roi_max_radius_px is None:
            raise DataError(
                "cannot write a crop without a ROI max radius (the format is positional)"
            )
        lines += [
            "",
            "#ROI max min radius",
            "",
            numbers([camera.roi_max_radius_px, camera.roi_min_radius_px]),
        ]
    if has_crop:
        lines += [
            "",
            "#left right cropped pixel",
            "",
            f"{camera.crop_left_px} {camera.crop_right_px}",
        ]
    Path(path).write_text("\n".join(lines) + "\n")
