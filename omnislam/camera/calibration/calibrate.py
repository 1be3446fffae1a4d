"""``calibrate``: initialise and fit one of the package's camera models to board views.

The unified model is always fitted first (grid initialisation, then the joint fit from the
best few candidates, keeping the one with the smallest inlier residual); the OCamCalib model
starts from it, the hyperbolic model from its own grid about the unified principal point
(:mod:`~omnislam.camera.calibration.initialise`); both are then fitted jointly with the board
poses in their own parameters (:mod:`~omnislam.camera.calibration.fit`).
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable, Sequence
from enum import Enum

import numpy as np

from omnislam.camera.base import CameraModel
from omnislam.camera.calibration.board import BoardView
from omnislam.camera.calibration.fit import Calibration, fit
from omnislam.camera.calibration.initialise import (
    HYPERBOLIC_XI_GRID,
    check_views,
    grid_candidates,
    hyperbolic_grid_camera,
    ocamcalib_from_unified,
    unified_grid_camera,
)
from omnislam.camera.calibration.parameters import (
    HyperbolicParameters,
    OCamCalibParameters,
    Parameterisation,
    UnifiedParameters,
)
from omnislam.camera.hyperbolic import HyperbolicCamera
from omnislam.camera.ocamcalib import OCamCalibCamera
from omnislam.camera.unified import UnifiedCamera
from omnislam.errors import EstimationError

#: fewest views a calibration accepts
MIN_VIEWS = 3
#: a unified candidate whose inlier sigma is below this [px] ends the search over candidates
GOOD_SIGMA_PX = 1.0
#: invpol: largest fitted degree, and the error it must reach over the fitted radii [px]
INVPOL_MAX_DEGREE = 20
INVPOL_TOL_PX = 0.01


class Model(Enum):
    """The camera models ``calibrate`` can fit (values: the ``model:`` key of the YAML)."""

    UNIFIED = "unified"
    OCAMCALIB = "ocamcalib"
    HYPERBOLIC = "hyperbolic"


def calibrate(
    views: Sequence[BoardView],
    model: Model,
    width: int,
    height: int,
    ocam_degree: int = 4,
    hyperbolic_template: HyperbolicCamera | None = None,
    progress: Callable[[str], None] | None = None,
) -> Calibration:
    """Fit ``model`` to the views.

    Args:
        views: the observed boards (>= ``MIN_VIEWS``).
        model: which camera model to fit.
        width: image width [px].
        height: image height [px].
        ocam_degree: degree of the OCamCalib ``pol``.
        hyperbolic_template: fixes the hyperbolic model's unobservable ``a_m`` and
            ``pixel_size_m`` (default: the package's default mirror and sensor).
        progress: called with one line per stage.

    Returns:
        The calibration.

    Raises:
        EstimationError: too few views, or no initialisation works.
    """
    check_views(views, MIN_VIEWS)
    say = progress or (lambda _line: None)
    side = min(width, height)
    template = UnifiedCamera(
        xi=1.0,
        gamma1=float(side),
        gamma2=float(side),
        cu=(width - 1) / 2.0,
        cv=(height - 1) / 2.0,
        width=width,
        height=height,
    )
    grid = grid_candidates(views, unified_grid_camera(template), side)
    best = _best_fit(views, UnifiedParameters(template), grid, "unified", say)
    if model is Model.UNIFIED:
        return best
    unified = best.camera
    assert isinstance(unified, UnifiedCamera)
    if model is Model.OCAMCALIB:
        ocam_template = OCamCalibCamera(
            pol=(-1.0, 0.0, 1e-3),
            invpol=(1.0,),
            center_row=unified.cv,
            center_col=unified.cu,
            c=1.0,
            d=0.0,
            e=0.0,
            width=width,
            height=height,
        )
        parameters = OCamCalibParameters(ocam_template, degree=ocam_degree, radius_px=side / 2.0)
        camera0, poses0 = ocamcalib_from_unified(
            unified,
            [view.cTb for view in best.views],
            views,
            ocam_template,
            ocam_degree,
            side / 2.0,
        )
        calibration = fit(views, parameters, camera0, poses0)
        say(f"ocamcalib: rms {calibration.rms_px:.3f} px")
        camera = calibration.camera
        assert isinstance(camera, OCamCalibCamera)
        pixels = np.concatenate([v.pixels for v in views])
        radius_px = np.hypot(pixels[:, 0] - camera.center_col, pixels[:, 1] - camera.center_row)
        invpol = fit_invpol(camera, 0.0, float(radius_px.max()) * 1.1)
        return dataclasses.replace(calibration, camera=dataclasses.replace(camera, invpol=invpol))
    hyper_template = hyperbolic_template or HyperbolicCamera(width=width, height=height)
    hyper_template = dataclasses.replace(hyper_template, width=width, height=height)
    make = hyperbolic_grid_camera(hyper_template, unified.cu, unified.cv)
    grid = grid_candidates(views, make, side, HYPERBOLIC_XI_GRID)
    return _best_fit(views, HyperbolicParameters(hyper_template), grid, "hyperbolic", say)


def _best_fit(
    views: Sequence[BoardView],
    parameters: Parameterisation,
    grid: list[tuple[CameraModel, list[np.ndarray]]],
    label: str,
    say: Callable[[str], None],
) -> Calibration:
    """Fit from the grid's candidates in order until one reaches ``GOOD_SIGMA_PX``; the best."""
    best: Calibration | None = None
    for rank, (camera0, poses0) in enumerate(grid, start=1):
        if best is not None and best.sigma_px <= GOOD_SIGMA_PX:
            break
        try:
            candidate = fit(views, parameters, camera0, poses0)
        except EstimationError as exc:
            say(f"{label} candidate {rank}: {exc}")
            continue
        say(
            f"{label} candidate {rank}: rms {candidate.rms_px:.3f} px "
            f"({candidate.nfev} evaluations)"
        )
        if best is None or candidate.sigma_px < best.sigma_px:
            best = candidate
    if best is None:
        raise EstimationError(f"no initial {label} camera converged")
    return best


def fit_invpol(camera: OCamCalibCamera, min_radius_px: float, max_radius_px: float) -> tuple:
    """The toolbox's ``world2cam`` polynomial ``rho = invpol(theta)`` for a fitted ``pol``.

    ``theta = atan2(pol(rho), rho)`` on radii ``[min, max]``; the degree grows until the
    largest radius error is below ``INVPOL_TOL_PX`` (as the toolbox's ``findinvpoly``).

    Returns:
        Coefficients in ascending powers of theta.
    """
    rho = np.linspace(max(min_radius_px, 1.0), max_radius_px, 2000)
    pol = np.asarray(camera.pol)
    theta = np.arctan2(np.polynomial.polynomial.polyval(rho, pol), rho)
    best: tuple[float, np.ndarray] | None = None
    for degree in range(2, INVPOL_MAX_DEGREE + 1):
        series = np.polynomial.Polynomial.fit(theta, rho, degree)
        error = float(np.max(np.abs(series(theta) - rho)))
        coefficients = series.convert().coef
        if best is None or error < best[0]:
            best = (error, coefficients)
        if error < INVPOL_TOL_PX:
            break
    assert best is not None
    return tuple(float(c) for c in best[1])
