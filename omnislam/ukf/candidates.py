"""The landmarks a frame can see, and where they should project (Barra & Costa sec. 3.2).

From the predicted pose: (1) drop landmarks farther than 50 m; (2) keep those whose ray to the
camera's centre of projection meets the image plane widened to twice its size; (3) drop those
whose ray crosses a wall of the map. The expected projection of a candidate is where its ray
meets the (1-D) image plane: ``ImageLine.u_px`` of its bearing.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from omnislam.core.measurement import Bearing2D
from omnislam.ukf.image_line import ImageLine

_BEARING = Bearing2D()


@dataclass(frozen=True, slots=True)
class Candidates:
    """Landmarks expected in view.

    Attributes:
        index: (C,) rows of the map's landmark arrays.
        bearings_rad: (C,) expected bearings in the robot frame.
        u_px: (C,) expected projections on the 1-D image [px].
    """

    index: np.ndarray
    bearings_rad: np.ndarray
    u_px: np.ndarray

    def __len__(self) -> int:
        return int(self.index.shape[0])


def occluded(
    origin_w: np.ndarray, points_w: np.ndarray, walls_w: np.ndarray, margin_m: float
) -> np.ndarray:
    """True where the segment origin -> point crosses a wall (sec. 3.2, last restriction).

    Args:
        origin_w: (2,) the centre of projection.
        points_w: (M, 2) landmarks.
        walls_w: (W, 2, 2) wall segments.
        margin_m: crossings within this distance of the landmark do not count (a door-frame
            line lies on its own wall).

    Returns:
        (M,) bool.
    """
    points_w = np.asarray(points_w, dtype=float)
    if not len(walls_w) or not len(points_w):
        return np.zeros(len(points_w), dtype=bool)
    d = points_w - origin_w  # (M, 2)
    a = walls_w[:, 0]  # (W, 2)
    e = walls_w[:, 1] - a  # (W, 2)
    # origin + t d = a + s e  ->  t d - s e = a - origin
    denom = d[:, None, 0] * (-e[None, :, 1]) - d[:, None, 1] * (-e[None, :, 0])  # (M, W)
    rhs = a - origin_w  # (W, 2)
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (rhs[None, :, 0] * (-e[None, :, 1]) - rhs[None, :, 1] * (-e[None, :, 0])) / denom
        s = (d[:, None, 0] * rhs[None, :, 1] - d[:, None, 1] * rhs[None, :, 0]) / denom
    length = np.linalg.norm(d, axis=1)
    t_max = 1.0 - margin_m / np.maximum(length, 1e-9)
    hit = (np.abs(denom) > 1e-12) & (t > 1e-9) & (t < t_max[:, None]) & (s >= 0) & (s <= 1)
    return hit.any(axis=1)


def select_candidates(
    wTr: np.ndarray,
    points_w: np.ndarray,
    walls_w: np.ndarray,
    image_line: ImageLine,
    max_range_m: float,
    wall_margin_m: float,
) -> Candidates:
    """The candidates of sec. 3.2 seen from the pose ``wTr`` = [x, y, theta].

    Args:
        points_w: (M, 2) landmark positions (the map's vertical lines).
        walls_w: (W, 2, 2) the map's main walls.

    Returns:
        Candidates (rows of ``points_w`` in increasing order).
    """
    wTr = np.asarray(wTr, dtype=float)
    points_w = np.asarray(points_w, dtype=float)
    near = np.hypot(points_w[:, 0] - wTr[0], points_w[:, 1] - wTr[1]) <= max_range_m
    index = np.flatnonzero(near)
    bearings = _BEARING.predict(wTr, points_w[index], jacobians=False)[0][:, 0]
    seen = image_line.in_widened_view(bearings)
    index, bearings = index[seen], bearings[seen]
    visible = ~occluded(wTr[:2], points_w[index], walls_w, wall_margin_m)
    index, bearings = index[visible], bearings[visible]
    return Candidates(index, bearings, image_line.u_px(bearings))
