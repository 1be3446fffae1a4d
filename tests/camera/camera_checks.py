"""Tolerances, reference cameras and sampling helpers shared by the camera tests."""

from __future__ import annotations

from functools import cache
from pathlib import Path

import numpy as np
import pytest

from omnislam.camera import (
    CameraModel,
    HyperbolicCamera,
    OCamCalibCamera,
    PinholeCamera,
    UnifiedCamera,
    hyperbolic_to_unified,
    read_ocamcalib,
)

#: project(unproject(u)) == u within this [px]
PIXEL_TOL_PX = 1e-6
#: unproject(project(x)) == x within this [rad]
RAY_TOL_RAD = 1e-9
#: relative error allowed between an analytic and a central-difference Jacobian
JACOBIAN_RTOL = 1e-6
#: samples per property-test example (the brief asks for >= 10 000 per model)
N_SAMPLES = 10_000

SHARED_DATA = Path(__file__).resolve().parents[2].parent / "shared" / "data"
OFFICE_CALIB = SHARED_DATA / "omni_real" / "office_ocamcalib" / "calib_results.txt"

#: the office calibration's numbers (copied from OFFICE_CALIB) so that the OCamCalib model is
#: exercised even where the shared data folder is absent; a test checks they agree with it
OFFICE_LIKE_OCAM = OCamCalibCamera(
    pol=(-2.665880e02, 0.0, 1.220001e-03, -5.781730e-07, 2.003631e-09),
    invpol=(
        443.183827,
        308.133563,
        28.505708,
        27.497972,
        26.856912,
        9.619478,
        1.117213,
        2.966127,
        3.206510,
        2.026977,
        0.948490,
        0.200601,
    ),
    center_row=545.872616,
    center_col=674.318875,
    c=0.999998,
    d=0.000003,
    e=0.000026,
    width=1300,
    height=1080,
    roi_min_radius_px=235.0,
    roi_max_radius_px=600.0,
    crop_left_px=300,
    crop_right_px=320,
)

#: a perspective camera with realistic distortion (VGA, ~65 deg horizontal field of view)
DISTORTED_PINHOLE = PinholeCamera(
    fx=500.0,
    fy=495.0,
    cu=321.3,
    cv=238.7,
    width=640,
    height=480,
    skew=0.2,
    k1=-0.2,
    k2=0.05,
    p1=1e-3,
    p2=-1e-3,
)

#: a unified camera with distortion and skew, ring mask like a real catadioptric image
DISTORTED_UNIFIED = UnifiedCamera(
    xi=0.9,
    gamma1=260.0,
    gamma2=258.0,
    cu=322.0,
    cv=317.0,
    width=640,
    height=640,
    skew=0.3,
    k1=-0.05,
    k2=0.004,
    p1=4e-4,
    p2=-3e-4,
    inner_radius_px=45.0,
    outer_radius_px=300.0,
)


def office_camera() -> OCamCalibCamera:
    """The real office calibration; skips the calling test when the data folder is absent."""
    if not OFFICE_CALIB.is_file():
        pytest.skip(f"real OCamCalib file not found at {OFFICE_CALIB}")
    return read_ocamcalib(OFFICE_CALIB)


@cache
def _models() -> dict[str, CameraModel]:
    hyperbolic = HyperbolicCamera()
    unified, _ = hyperbolic_to_unified(hyperbolic)
    return {
        "hyperbolic": hyperbolic,
        "unified-from-hyperbolic": unified,
        "unified-distorted": DISTORTED_UNIFIED,
        "ocamcalib-office-like": OFFICE_LIKE_OCAM,
        "pinhole-distorted": DISTORTED_PINHOLE,
    }


MODEL_NAMES = (
    "hyperbolic",
    "unified-from-hyperbolic",
    "unified-distorted",
    "ocamcalib-office-like",
    "ocamcalib-office-file",
    "pinhole-distorted",
)


def model(name: str) -> CameraModel:
    """A reference camera by name (the real office file skips when absent)."""
    if name == "ocamcalib-office-file":
        return office_camera()
    return _models()[name]


def angle_between(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(N,) angle between row vectors [rad], accurate for tiny angles (atan2 of |a x b|, a.b)."""
    return np.arctan2(np.linalg.norm(np.cross(a, b), axis=1), np.einsum("ij,ij->i", a, b))


def mask_center(camera: CameraModel) -> tuple[float, float]:
    """The centre of a camera's mask ring (principal point / distortion centre) [px]."""
    if isinstance(camera, OCamCalibCamera):
        return camera.center_col, camera.center_row
    return camera.cu, camera.cv


def sample_mask_pixels(camera: CameraModel, n: int, rng: np.random.Generator) -> np.ndarray:
    """(n, 2) pixels drawn uniformly over the camera's usable region (``in_mask``)."""
    out = np.zeros((0, 2))
    while len(out) < n:
        draw = rng.uniform([-0.5, -0.5], [camera.width - 0.5, camera.height - 0.5], (2 * n, 2))
        out = np.vstack([out, draw[camera.in_mask(draw)]])
    return out[:n]


def sample_mask_directions(camera: CameraModel, n: int, rng: np.random.Generator) -> np.ndarray:
    """(n, 3) unit directions drawn uniformly on the sphere among those imaged in the mask.

    The band of angles from the camera's z axis covered by the mask is found once from the
    rays of dense mask pixels; directions are drawn uniformly in that band and kept when they
    project validly into the mask (so ``unproject`` is not used to make the samples).
    """
    band = camera.unproject(sample_mask_pixels(camera, 20_000, np.random.default_rng(0)))
    cos_lo, cos_hi = band[:, 2].min() - 1e-3, band[:, 2].max() + 1e-3
    out = np.zeros((0, 3))
    while len(out) < n:
        cos_t = rng.uniform(max(cos_lo, -1.0), min(cos_hi, 1.0), 2 * n)
        azimuth = rng.uniform(-np.pi, np.pi, 2 * n)
        sin_t = np.sqrt(1.0 - cos_t**2)
        rays = np.column_stack([sin_t * np.cos(azimuth), sin_t * np.sin(azimuth), cos_t])
        pixels, valid = camera.project(rays)
        keep = valid & camera.in_mask(np.nan_to_num(pixels, nan=-1e9))
        out = np.vstack([out, rays[keep]])
    return out[:n]


def central_difference_jacobian(
    camera: CameraModel, points_c: np.ndarray, rel_step: float = 1e-5
) -> np.ndarray:
    """(N, 2, 3) central-difference Jacobian of ``camera.project`` (step ``rel_step |X|``)."""
    step = rel_step * np.linalg.norm(points_c, axis=1)
    J = np.empty((len(points_c), 2, 3))
    for axis in range(3):
        offset = np.zeros_like(points_c)
        offset[:, axis] = step
        plus, _ = camera.project(points_c + offset)
        minus, _ = camera.project(points_c - offset)
        J[:, :, axis] = (plus - minus) / (2.0 * step[:, None])
    return J
