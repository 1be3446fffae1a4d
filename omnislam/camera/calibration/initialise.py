"""Initial camera and board poses: a grid over ``(xi, gamma)``, DLT poses, model conversion.

Unified (Mei) model. With the principal point at the image centre and no distortion, each
candidate ``(xi, gamma)`` of a coarse grid lifts the observed corners to rays; since the board
is planar, the rays satisfy ``r_j ~ H [x_j, y_j, 1]`` with ``H = [r1 r2 t]`` (up to a positive
scale), which a direct linear transform on ``r_j x H q_j = 0`` solves per view (Hartley &
Zisserman 2004, alg. 4.2, on rays instead of image points). ``H`` is scaled so that its first
two columns have unit norm on average, its sign fixed so the board lies in front of the rays,
and ``[r1 r2 r1 x r2]`` projected on the rotations. The candidate whose poses reproject best
(median of the per-view RMS) starts the joint fit.

The hyperbolic model runs the same grid over the mirrors and lenses that image like a unified
``(xi < 1, gamma)`` (:func:`hyperbolic_shape`), the principal point that of the unified fit.

The OCamCalib model starts from the fitted unified camera: centre ``(cv, cu)``, affine
identity, and ``pol`` by linear least squares from the unified rays of the observed corners
(``f(rho) = z rho / |[x, y]|`` in OCamCalib's frame, ``X_o = M_ou X_u`` with
``M_ou = [[0, 1, 0], [1, 0, 0], [0, 0, -1]]``: rows first, ``z`` towards the mirror).

Board poses follow through :func:`~omnislam.camera.calibration.board.transfer_pose`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence

import numpy as np

from omnislam.camera.base import CameraModel
from omnislam.camera.calibration.board import BoardView, transfer_pose
from omnislam.camera.calibration.fit import hat
from omnislam.camera.hyperbolic import HyperbolicCamera
from omnislam.camera.ocamcalib import OCamCalibCamera
from omnislam.camera.unified import UnifiedCamera
from omnislam.errors import DataError, EstimationError

#: candidate xi of the grid search (xi = 1: parabolic mirror)
XI_GRID = (0.6, 0.8, 1.0, 1.2)
#: candidate gamma of the grid search, as fractions of min(width, height)
GAMMA_GRID = tuple(np.geomspace(0.1, 2.0, 16))
#: candidate xi of the hyperbolic model's grid (a hyperbolic mirror has 0 < xi < 1)
HYPERBOLIC_XI_GRID = (0.6, 0.75, 0.85, 0.92, 0.97)
#: OCamCalib frame from the unified frame (rows first, z towards the mirror); a rotation
M_OCAM_FROM_UNIFIED = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
M_OCAM_FROM_UNIFIED.setflags(write=False)


def pose_from_rays(rays_c: np.ndarray, points_b: np.ndarray) -> np.ndarray | None:
    """Board pose from unit rays to its corners (planar DLT, see the module docstring).

    Args:
        rays_c: (N, 3) unit rays in the camera frame, N >= 4.
        points_b: (N, 3) the corners in the board frame [m], ``z = 0``.

    Returns:
        (4, 4) ``cTb``, or None when the rays are degenerate (NaN, collinear corners).
    """
    if len(rays_c) < 4 or not np.all(np.isfinite(rays_c)):
        return None
    xy = points_b[:, :2]
    centre = xy.mean(axis=0)
    spread = np.sqrt(np.mean(np.sum((xy - centre) ** 2, axis=1)))
    if spread == 0.0:
        return None
    T = np.array([[1 / spread, 0, -centre[0] / spread], [0, 1 / spread, -centre[1] / spread]])
    T = np.vstack([T, [0.0, 0.0, 1.0]])
    q = np.column_stack([xy, np.ones(len(xy))]) @ T.T
    A = np.einsum("nia,nb->niab", hat(rays_c), q).reshape(-1, 9)
    _, _, Vt = np.linalg.svd(A, full_matrices=False)
    H = Vt[-1].reshape(3, 3) @ T
    points_h = np.column_stack([xy, np.ones(len(xy))])
    if np.sum(np.einsum("ij,ij->i", rays_c, points_h @ H.T)) < 0:
        H = -H
    scale = 2.0 / (np.linalg.norm(H[:, 0]) + np.linalg.norm(H[:, 1]))
    r1, r2 = scale * H[:, 0], scale * H[:, 1]
    U, _, Vt3 = np.linalg.svd(np.column_stack([r1, r2, np.cross(r1, r2)]))
    R = U @ Vt3
    if np.linalg.det(R) < 0:  # pragma: no cover - the columns above are right-handed
        R = U @ np.diag([1.0, 1.0, -1.0]) @ Vt3
    cTb = np.eye(4)
    cTb[:3, :3] = R
    cTb[:3, 3] = scale * H[:, 2]
    return cTb


def _reprojection_rms(camera: CameraModel, view: BoardView, cTb: np.ndarray) -> float:
    points_c = view.points_b @ cTb[:3, :3].T + cTb[:3, 3]
    pixels, _ = camera.project(points_c)
    error = np.sum((pixels - view.pixels) ** 2, axis=1)
    return float(np.sqrt(np.mean(error))) if np.all(np.isfinite(error)) else np.inf


def poses_for(camera: CameraModel, views: Sequence[BoardView]) -> list[np.ndarray | None]:
    """Per view, the DLT pose of its corners' rays under ``camera`` (None if degenerate)."""
    return [pose_from_rays(camera.unproject(view.pixels), view.points_b) for view in views]


def grid_candidates(
    views: Sequence[BoardView],
    make_camera: Callable[[float, float], CameraModel | None],
    side_px: int,
    xis: Sequence[float] = XI_GRID,
    candidates: int = 3,
) -> list[tuple[CameraModel, list[np.ndarray]]]:
    """The best cameras of a grid over ``(xi, gamma)`` and their DLT board poses.

    Args:
        views: the observed boards.
        make_camera: the camera of one grid point (None when the model has none there).
        side_px: ``min(width, height)``; the gammas are ``GAMMA_GRID`` times it.
        xis: the grid's xi values.
        candidates: how many of the best candidates to return.

    Returns:
        Up to ``candidates`` ``(camera, cTbs)`` pairs, best (median per-view RMS) first.

    Raises:
        EstimationError: no candidate gives a pose for every view.
    """
    scored: list[tuple[float, CameraModel, list[np.ndarray]]] = []
    for xi in xis:
        for fraction in GAMMA_GRID:
            camera = make_camera(xi, fraction * side_px)
            if camera is None:
                continue
            poses = poses_for(camera, views)
            if any(cTb is None for cTb in poses):
                continue
            rms = [_reprojection_rms(camera, v, cTb) for v, cTb in zip(views, poses, strict=True)]
            score = float(np.median(rms))
            if np.isfinite(score):
                scored.append((score, camera, poses))  # type: ignore[arg-type]
    if not scored:
        raise EstimationError("no initial camera of the grid lifts every view's corners")
    scored.sort(key=lambda item: item[0])
    return [(camera, poses) for _, camera, poses in scored[:candidates]]


def unified_grid_camera(template: UnifiedCamera) -> Callable[[float, float], UnifiedCamera]:
    """Grid points of the unified model: ``template`` with ``xi``, ``gamma``, no distortion."""

    def make(xi: float, gamma: float) -> UnifiedCamera:
        return dataclasses.replace(
            template, xi=xi, gamma1=gamma, gamma2=gamma, k1=0.0, k2=0.0, p1=0.0, p2=0.0, skew=0.0
        )

    return make


def hyperbolic_grid_camera(
    template: HyperbolicCamera, cu: float, cv: float
) -> Callable[[float, float], HyperbolicCamera | None]:
    """Grid points of the hyperbolic model: the mirror and lens of a unified ``(xi, gamma)``."""

    def make(xi: float, gamma: float) -> HyperbolicCamera | None:
        if not 0.0 < xi < 1.0:
            return None
        b_m, focal_length_m = hyperbolic_shape(xi, gamma, template.a_m, template.pixel_size_m)
        try:
            return dataclasses.replace(
                template, b_m=b_m, focal_length_m=focal_length_m, cu=cu, cv=cv, z_h_m=None
            )
        except DataError:
            return None

    return make


def hyperbolic_shape(
    xi: float, gamma: float, a_m: float, pixel_size_m: float
) -> tuple[float, float]:
    """``(b_m, focal_length_m)`` of the hyperbolic camera imaging like unified ``(xi, gamma)``.

    ``e / a = (1 + sqrt(1 - xi^2)) / xi``, ``b = a sqrt((e/a)^2 - 1)``,
    ``f / pixel = gamma (a^2 + e^2) / b^2`` (:func:`hyperbolic_to_unified` backwards).
    """
    ratio = (1.0 + np.sqrt(1.0 - xi**2)) / xi
    e = ratio * a_m
    b = a_m * np.sqrt(ratio**2 - 1.0)
    return float(b), float(gamma * (a_m**2 + e**2) / b**2 * pixel_size_m)


def ocamcalib_from_unified(
    unified: UnifiedCamera,
    cTbs_u: Sequence[np.ndarray],
    views: Sequence[BoardView],
    template: OCamCalibCamera,
    degree: int,
    radius_px: float,
) -> tuple[OCamCalibCamera, list[np.ndarray]]:
    """Initial OCamCalib camera and poses from a unified fit (see the module docstring)."""
    pixels = np.concatenate([v.pixels for v in views])
    rays_o = unified.unproject(pixels) @ M_OCAM_FROM_UNIFIED.T
    rho = np.hypot(pixels[:, 1] - unified.cv, pixels[:, 0] - unified.cu)
    target = rays_o[:, 2] * rho / np.hypot(rays_o[:, 0], rays_o[:, 1])
    powers = np.array([0, *range(2, degree + 1)])
    A = (rho[:, None] / radius_px) ** powers[None, :]
    scaled, *_ = np.linalg.lstsq(A, target, rcond=None)
    pol = np.zeros(degree + 1)
    pol[powers] = scaled / radius_px ** powers.astype(float)
    camera = dataclasses.replace(
        template,
        pol=tuple(pol),
        center_row=unified.cv,
        center_col=unified.cu,
        c=1.0,
        d=0.0,
        e=0.0,
        world2cam="exact",
    )
    return camera, [transfer_pose(M_OCAM_FROM_UNIFIED, cTb) for cTb in cTbs_u]


def check_views(views: Sequence[BoardView], minimum: int) -> None:
    """Raise EstimationError unless there are at least ``minimum`` views."""
    if len(views) < minimum:
        raise EstimationError(f"{len(views)} usable image(s); a calibration needs >= {minimum}")
