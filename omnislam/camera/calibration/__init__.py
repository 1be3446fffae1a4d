"""Calibration of the package's camera models from checkerboard images.

Corner points (detected by :mod:`.detect` or read by :mod:`.points_io`) become
:class:`BoardView` records; :func:`calibrate` initialises one model and fits it jointly with
every board pose (:mod:`.fit`), returning a :class:`Calibration` with per-view residuals and
the parameters' standard deviations. Imports of OpenCV are lazy (only :mod:`.detect` and
:mod:`.render` need it).
"""

from omnislam.camera.calibration.board import Board, BoardView, Skipped, transfer_pose
from omnislam.camera.calibration.calibrate import MIN_VIEWS, Model, calibrate, fit_invpol
from omnislam.camera.calibration.fit import Calibration, ViewFit, fit
from omnislam.camera.calibration.points_io import (
    read_points,
    read_points_csv,
    read_points_mat,
    write_points_csv,
)

__all__ = [
    "MIN_VIEWS",
    "Board",
    "BoardView",
    "Calibration",
    "Model",
    "Skipped",
    "ViewFit",
    "calibrate",
    "fit",
    "fit_invpol",
    "read_points",
    "read_points_csv",
    "read_points_mat",
    "transfer_pose",
    "write_points_csv",
]
