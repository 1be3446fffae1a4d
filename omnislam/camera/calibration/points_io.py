"""Corner-point files: the calibration toolboxes' ``.mat`` and a plain CSV (``read_*``/``write_*``).

``.mat`` (Bouguet's and Mei's MATLAB toolboxes, the ``gridInfo`` struct also found next to the
OCamCalib samples): per image ``x`` (2 x N image points, MATLAB's 1-based pixel convention),
``X`` (3 x N board points in the toolbox unit, millimetres), ``n_sq_x``/``n_sq_y`` (squares,
so ``n_sq + 1`` corners) and ``dX``/``dY`` (square size, mm). The loader converts once: pixels
``- 1`` into this package's convention (``(0, 0)`` at the centre of the top-left pixel;
checked on the VMR samples, where OpenCV's ``cornerSubPix`` with the toolbox's window
reproduces the file's points to 0.001 px after the shift) and board points to metres.

CSV: a header and one row per corner, ``image,u,v,x_m,y_m`` (pixels in this package's
convention, board points in metres, ``z = 0``); the ``x_m,y_m`` columns may be left out when a
:class:`Board` is given, the corners then being in the board's row-by-row order.

Problems confined to one image (inconsistent point counts, a board that disagrees with the
points) do not raise: that image is returned as :class:`Skipped` with a one-line reason and
the others are kept. A file that cannot be read at all raises DataError.
"""

from __future__ import annotations

import csv
import io
import struct
import zlib
from pathlib import Path

import numpy as np

from omnislam.camera.calibration.board import Board, BoardView, Skipped
from omnislam.errors import DataError

#: the toolbox's board unit [m]
MAT_UNIT_M = 1e-3
#: MATLAB pixel index of the centre of the top-left pixel (ours is 0)
MAT_PIXEL_ORIGIN = 1.0
#: relative tolerance when comparing a given square size with a file's
SQUARE_RTOL = 1e-6
CSV_COLUMNS = ("image", "u", "v", "x_m", "y_m")


def read_points(
    path: str | Path,
    board: Board | None = None,
    names: list[str] | None = None,
    check_square: bool = True,
) -> tuple[list[BoardView], list[Skipped]]:
    """Read a ``.mat`` or ``.csv`` points file (dispatch on the suffix)."""
    path = Path(path)
    if path.suffix.lower() == ".mat":
        return read_points_mat(path, board, names, check_square)
    if path.suffix.lower() == ".csv":
        return read_points_csv(path, board)
    raise DataError("points file must end in .mat or .csv", path)


def _scalar(value: object) -> float | None:
    array = np.asarray(value, dtype=float).ravel()
    return float(array[0]) if array.size == 1 else None


def read_points_mat(
    path: str | Path,
    board: Board | None = None,
    names: list[str] | None = None,
    check_square: bool = True,
) -> tuple[list[BoardView], list[Skipped]]:
    """Read the toolbox's ``gridInfo`` (see the module docstring).

    Args:
        path: the ``.mat`` file.
        board: the board the user states; each image whose corner count or square size
            disagrees with it is skipped. None: the file's geometry is used as it is.
        names: one name per image of the file (e.g. the image files); default ``image<k>``.
        check_square: compare ``board.square_m`` with the file's square size too.

    Returns:
        ``(views, skipped)`` in the file's order.

    Raises:
        DataError: unreadable or corrupt file, no ``gridInfo`` with ``x`` and ``X``, or a
            wrong number of names.
    """
    import scipy.io

    path = Path(path)
    try:
        mat = scipy.io.loadmat(path)
    except (OSError, ValueError, NotImplementedError) as exc:
        raise DataError(f"cannot read MATLAB file: {exc}", path) from exc
    except (zlib.error, IndexError, EOFError, struct.error) as exc:  # damaged compressed data
        raise DataError(f"corrupt MATLAB file ({type(exc).__name__}: {exc})", path) from None
    if "gridInfo" not in mat:
        raise DataError("no 'gridInfo' struct (the calibration toolbox's points)", path)
    grid = mat["gridInfo"]
    fields = grid.dtype.names or ()
    if "x" not in fields or "X" not in fields:
        raise DataError("gridInfo needs the fields 'x' (image points) and 'X' (board)", path)
    grid = grid[0, 0]
    xs, Xs = grid["x"].ravel(), grid["X"].ravel()
    if len(xs) != len(Xs):
        raise DataError(f"gridInfo has {len(xs)} 'x' entries but {len(Xs)} 'X' entries", path)
    if names is not None and len(names) != len(xs):
        raise DataError(f"{len(names)} image name(s) given for {len(xs)} images in the file", path)
    names = names or [f"image{k}" for k in range(len(xs))]

    def per_image(field: str, k: int) -> float | None:
        if field not in fields:
            return None
        values = grid[field].ravel()
        return _scalar(values[k]) if k < len(values) else None

    views: list[BoardView] = []
    skipped: list[Skipped] = []
    for k, (x, X) in enumerate(zip(xs, Xs, strict=True)):
        x = np.asarray(x, dtype=float)
        X = np.asarray(X, dtype=float)
        name = names[k]
        if x.ndim != 2 or x.shape[0] != 2 or X.ndim != 2 or X.shape[0] not in (2, 3):
            skipped.append(Skipped(name, f"points of shape {x.shape} / board {X.shape}"))
            continue
        if x.shape[1] != X.shape[1]:
            skipped.append(
                Skipped(name, f"{x.shape[1]} image points but {X.shape[1]} board points")
            )
            continue
        n_sq_x, n_sq_y = per_image("n_sq_x", k), per_image("n_sq_y", k)
        square = per_image("dX", k)
        if board is not None:
            problem = _board_disagreement(
                board, x.shape[1], n_sq_x, n_sq_y, square if check_square else None
            )
            if problem:
                skipped.append(Skipped(name, problem))
                continue
        points_b = np.zeros((x.shape[1], 3))
        points_b[:, : X.shape[0]] = X.T * MAT_UNIT_M
        try:
            views.append(BoardView(name, x.T - MAT_PIXEL_ORIGIN, points_b))
        except DataError as exc:
            skipped.append(Skipped(name, str(exc).removeprefix(f"{name}: ")))
    return views, skipped


def _board_disagreement(
    board: Board, count: int, n_sq_x: float | None, n_sq_y: float | None, square_mm: float | None
) -> str | None:
    """The one-line reason why a file's image disagrees with the stated board, else None."""
    if n_sq_x is not None and n_sq_y is not None:
        file_corners = {int(n_sq_x) + 1, int(n_sq_y) + 1}
        if file_corners != {board.cols, board.rows}:
            return (
                f"board {board.cols}x{board.rows} given but the file says "
                f"{int(n_sq_x) + 1}x{int(n_sq_y) + 1} corners"
            )
    if count != board.size:
        return f"{count} points but the {board.cols}x{board.rows} board has {board.size} corners"
    if square_mm is not None and not np.isclose(
        square_mm * MAT_UNIT_M, board.square_m, rtol=SQUARE_RTOL
    ):
        return f"square {board.square_m:g} m given but the file says {square_mm * MAT_UNIT_M:g} m"
    return None


def read_points_csv(
    path: str | Path, board: Board | None = None
) -> tuple[list[BoardView], list[Skipped]]:
    """Read ``image,u,v[,x_m,y_m]`` rows (see the module docstring), grouped by image.

    Raises:
        DataError: unreadable file, a missing column, a non-numeric value (naming the line),
            or no board coordinates and no ``board``.
    """
    path = Path(path)
    try:
        text = path.read_text()
    except (OSError, UnicodeDecodeError) as exc:
        raise DataError(f"cannot read points file: {exc}", path) from exc
    reader = csv.DictReader(io.StringIO(text))
    header = [name.strip() for name in reader.fieldnames or []]
    missing = [c for c in CSV_COLUMNS[:3] if c not in header]
    if missing:
        raise DataError(f"missing column(s) {', '.join(missing)} (need {CSV_COLUMNS})", path)
    has_board = "x_m" in header and "y_m" in header
    if not has_board and board is None:
        raise DataError("no x_m,y_m columns: give the board (--board, --square)", path)
    rows: dict[str, list[list[float]]] = {}
    for line, row in enumerate(reader, start=2):
        row = {key.strip(): (value or "").strip() for key, value in row.items() if key}
        try:
            values = [float(row[c]) for c in (CSV_COLUMNS[1:] if has_board else ("u", "v"))]
        except (TypeError, ValueError):
            raise DataError(f"line {line}: expected numbers, got {row!r}", path) from None
        rows.setdefault(row["image"], []).append(values)
    views: list[BoardView] = []
    skipped: list[Skipped] = []
    for name, values in rows.items():
        array = np.asarray(values)
        if board is not None and len(array) != board.size:
            skipped.append(
                Skipped(
                    name,
                    f"{len(array)} points but the {board.cols}x{board.rows} board has "
                    f"{board.size} corners",
                )
            )
            continue
        points_b = np.zeros((len(array), 3))
        points_b[:, :2] = array[:, 2:4] if has_board else board.points_b()[:, :2]
        try:
            views.append(BoardView(name, array[:, :2], points_b))
        except DataError as exc:
            skipped.append(Skipped(name, str(exc).removeprefix(f"{name}: ")))
    return views, skipped


def write_points_csv(views: list[BoardView], path: str | Path) -> None:
    """Write views as ``image,u,v,x_m,y_m`` rows (``repr`` precision; read back equal)."""
    from omnislam._files import atomic_write_text

    lines = [",".join(CSV_COLUMNS)]
    for view in views:
        if "," in view.name or "\n" in view.name:
            raise DataError(f"image name {view.name!r} cannot be written to a CSV cell")
        for (u, v), (x, y, _) in zip(view.pixels, view.points_b, strict=True):
            lines.append(f"{view.name},{float(u)!r},{float(v)!r},{float(x)!r},{float(y)!r}")
    atomic_write_text(path, "\n".join(lines) + "\n")
