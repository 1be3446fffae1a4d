"""Checkerboard corners on raw omnidirectional images (OpenCV, imported lazily).

The detector runs on the image with the unusable region masked (outside the mirror ring,
when a mask is given), first OpenCV's classic ``findChessboardCorners`` (adaptive threshold)
and, where it fails, the sector-based ``findChessboardCornersSB``. The corners are then
refined to sub-pixel on the **original** image with ``cornerSubPix`` in a
``(2 w + 1)``-pixel window: ``w = 4`` is the default window of the MATLAB toolboxes
(``wintx = winty = 4``), and on the VMR samples it reproduces the toolbox's points within
0.001 px (median). A board imaged by a catadioptric camera is curved, but over one 9 x 9
window a corner is still the saddle point that ``cornerSubPix`` models: on the package's
rendered boards (:mod:`~omnislam.camera.calibration.render`, 4 x 4 supersampling) the refined
corners lie 0.06 px RMS from the exact projection (0.05 px with 8 x 8, 0.10 px with 2 x 2,
where the box filter's aliasing, not the window, dominates).

OpenCV pixels have ``(0, 0)`` at the centre of the top-left pixel, as this package.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from omnislam._optional import require
from omnislam.camera.calibration.board import Board, BoardView, Skipped
from omnislam.camera.image_file import read_image
from omnislam.errors import DataError

#: half-size of the sub-pixel window [px] (the toolboxes' wintx)
DEFAULT_WINDOW_PX = 4
#: cornerSubPix stop: iterations, and the corner's last move [px]
SUBPIX_MAX_ITER = 100
SUBPIX_EPS_PX = 1e-4
#: grey level given to masked pixels
MASK_FILL = 128


def detect_corners(
    image: np.ndarray,
    board: Board,
    mask: np.ndarray | None = None,
    window_px: int = DEFAULT_WINDOW_PX,
) -> np.ndarray | None:
    """The board's inner corners in one grey image, or None when the board is not found.

    Args:
        image: (H, W) uint8 grey image.
        board: the board (its ``cols x rows`` inner corners).
        mask: (H, W) bool, True where the detector may look (None: everywhere).
        window_px: half-size of the sub-pixel window [px].

    Returns:
        (cols * rows, 2) corners ``[u, v]`` [px] in OpenCV's order (row by row of the
        pattern), refined on the original image; None if no detector finds the board.
    """
    cv2 = require("cv2")
    work = image
    if mask is not None:
        work = image.copy()
        work[~mask] = MASK_FILL
    pattern = (board.cols, board.rows)
    found, corners = cv2.findChessboardCorners(
        work, pattern, flags=cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE
    )
    if not found:
        found, corners = cv2.findChessboardCornersSB(
            work, pattern, flags=cv2.CALIB_CB_EXHAUSTIVE | cv2.CALIB_CB_ACCURACY
        )
    if not found:
        return None
    criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, SUBPIX_MAX_ITER, SUBPIX_EPS_PX)
    refined = cv2.cornerSubPix(
        image, corners.astype(np.float32), (window_px, window_px), (-1, -1), criteria
    )
    return refined.reshape(-1, 2).astype(float)


def read_grey(path: str | Path) -> np.ndarray:
    """An image file as a (H, W) uint8 grey array.

    Raises:
        DataError: naming the file: unreadable, truncated or corrupt, or not an image
            (``camera.image_file.read_image``).
    """
    return read_image(path, grey=True)


def detect_views(
    paths: Sequence[str | Path],
    board: Board,
    mask: np.ndarray | None = None,
    window_px: int = DEFAULT_WINDOW_PX,
) -> tuple[list[BoardView], list[Skipped], tuple[int, int] | None]:
    """Detect the board in every image.

    Returns:
        ``(views, skipped, (width, height))``: one view per image where the board was found
        (named by the file name), the images left out with the reason, and the size of the
        first readable image (None if none); images of another size are skipped.
    """
    views: list[BoardView] = []
    skipped: list[Skipped] = []
    size: tuple[int, int] | None = None
    points_b = board.points_b()
    for path in paths:
        name = Path(path).name
        try:
            image = read_grey(path)
        except DataError as exc:
            skipped.append(Skipped(name, exc.reason))
            continue
        shape = (image.shape[1], image.shape[0])
        if size is None:
            size = shape
        elif shape != size:
            skipped.append(
                Skipped(name, f"image is {shape[0]}x{shape[1]}, others {size[0]}x{size[1]}")
            )
            continue
        if mask is not None and mask.shape != image.shape:
            skipped.append(Skipped(name, f"mask of shape {mask.shape} for an image {image.shape}"))
            continue
        corners = detect_corners(image, board, mask, window_px)
        if corners is None:
            skipped.append(Skipped(name, f"board {board.cols}x{board.rows} not found"))
            continue
        views.append(BoardView(name, corners, points_b))
    return views, skipped, size
