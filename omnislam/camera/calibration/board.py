"""Checkerboard geometry and the corner observations of one image (``BoardView``).

Board frame ``b``: origin at the first inner corner, ``x`` along the rows of corners (the
``cols`` direction), ``y`` along the columns, ``z = 0`` on the board; units are metres.
Corners are ordered row by row, ``cols`` per row, the order of OpenCV's
``findChessboardCorners`` for ``patternSize = (cols, rows)``.

A planar target is the reason a board pose can always be a proper rotation, whatever the
handedness of the camera frame: for an improper ``M`` and ``N = diag(1, 1, -1)``,
``M (R p + t) = (M R N) p + M t`` for every ``p`` with ``p_z = 0`` and ``det(M R N) = +1``
(:func:`transfer_pose`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from omnislam.errors import DataError

#: ``N`` of :func:`transfer_pose`: the reflection that leaves the board plane z = 0 fixed
BOARD_REFLECTION = np.diag([1.0, 1.0, -1.0])
BOARD_REFLECTION.setflags(write=False)


@dataclass(frozen=True, slots=True)
class Board:
    """A checkerboard of ``cols x rows`` inner corners spaced ``square_m`` apart.

    Attributes:
        cols: inner corners per row (OpenCV ``patternSize[0]``).
        rows: rows of inner corners (OpenCV ``patternSize[1]``).
        square_m: side of a square [m].
    """

    cols: int
    rows: int
    square_m: float

    def __post_init__(self) -> None:
        for label, value in (("cols", self.cols), ("rows", self.rows)):
            if isinstance(value, bool) or not isinstance(value, (int, np.integer)) or value < 2:
                raise DataError(f"Board.{label} must be an integer >= 2, got {value!r}")
        if not np.isfinite(self.square_m) or self.square_m <= 0.0:
            raise DataError(f"Board.square_m must be positive, got {self.square_m!r}")

    @classmethod
    def parse(cls, text: str, square_m: float) -> Board:
        """``"COLSxROWS"`` (inner corners, e.g. ``"6x7"``) and the square size [m]."""
        cols, sep, rows = text.lower().partition("x")
        if not sep or not cols.strip().isdigit() or not rows.strip().isdigit():
            raise DataError(f"--board must be COLSxROWS (inner corners, e.g. 6x7), got {text!r}")
        return cls(int(cols), int(rows), float(square_m))

    @property
    def size(self) -> int:
        """Number of inner corners."""
        return self.cols * self.rows

    def points_b(self) -> np.ndarray:
        """(cols * rows, 3) corner positions in the board frame [m], row by row."""
        j, i = np.mgrid[0 : self.rows, 0 : self.cols]
        return np.column_stack(
            [i.ravel() * self.square_m, j.ravel() * self.square_m, np.zeros(self.size)]
        )

    def __str__(self) -> str:
        return f"{self.cols}x{self.rows} corners of {self.square_m:g} m"


@dataclass(frozen=True, slots=True)
class BoardView:
    """The corners of one board seen in one image.

    Attributes:
        name: the image (file name, or the index in a points file).
        pixels: (N, 2) observed corners ``[u, v]`` [px], package convention (``(0, 0)`` at the
            centre of the top-left pixel).
        points_b: (N, 3) the same corners in the board frame [m] (``z = 0``).
    """

    name: str
    pixels: np.ndarray
    points_b: np.ndarray

    def __post_init__(self) -> None:
        pixels = np.array(self.pixels, dtype=float)
        points_b = np.array(self.points_b, dtype=float)
        if pixels.ndim != 2 or pixels.shape[1] != 2:
            raise DataError(f"{self.name}: pixels must have shape (N, 2), got {pixels.shape}")
        if points_b.shape != (len(pixels), 3):
            raise DataError(
                f"{self.name}: {len(pixels)} image points but board points of shape "
                f"{points_b.shape}"
            )
        if not (np.all(np.isfinite(pixels)) and np.all(np.isfinite(points_b))):
            raise DataError(f"{self.name}: points contain NaN or infinite values")
        if np.any(np.abs(points_b[:, 2]) > 1e-9 * (1.0 + np.abs(points_b).max())):
            raise DataError(f"{self.name}: board points must lie on the plane z = 0")
        pixels.setflags(write=False)
        points_b.setflags(write=False)
        object.__setattr__(self, "pixels", pixels)
        object.__setattr__(self, "points_b", points_b)


@dataclass(frozen=True, slots=True)
class Skipped:
    """An image left out of the calibration, and why (one line for the user)."""

    name: str
    reason: str

    def __str__(self) -> str:
        return f"{self.name}: {self.reason}; skipped"


def transfer_pose(M: np.ndarray, cTb: np.ndarray) -> np.ndarray:
    """The board pose in a camera frame ``c'`` related to ``c`` by ``X_c' = M X_c``.

    Args:
        M: (3, 3) orthogonal, proper or improper (a change of camera-frame convention).
        cTb: (4, 4) board pose in ``c``.

    Returns:
        (4, 4) ``c'Tb`` with a proper rotation: ``M R`` when ``det M = 1``, ``M R N`` with
        ``N = diag(1, 1, -1)`` otherwise (exact for the planar board, see the module docstring).
    """
    out = np.eye(4)
    R = M @ cTb[:3, :3]
    out[:3, :3] = R if np.linalg.det(M) > 0 else R @ BOARD_REFLECTION
    out[:3, 3] = M @ cTb[:3, 3]
    return out
