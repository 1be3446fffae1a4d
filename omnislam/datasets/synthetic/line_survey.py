"""The colour descriptors (MC) of a world's vertical lines, surveyed while rendering.

Barra & Costa's map stores, with each vertical-line landmark, its MC: the mean colour left and
right of the line in each band (sec. 2.2), measured beforehand. A synthetic world has the
lines' positions but not their colours in the camera; this survey measures them the way the
localiser will see them: in every rendered image, the shared front end's vertical lines
(``frontend.vertical_edges``) are extracted, each world line the renderer shows (visible at its
true projection, ``frontend.evaluation.visible_lines``) takes the nearest extracted line
within ``TOL_RAD`` (one to one), and a landmark's MC is the mean of its lines' MCs over all
images. The result is the folder's ``line_colours.csv``, which the loader puts into the prior
map (``PriorMap.means_left`` / ``means_right``).
"""

from __future__ import annotations

import numpy as np

#: an extracted line is the image of a world line whose true bearing is this close [rad]
#: (2 px at corridor21's f = 400 px)
TOL_RAD = 0.005


class LineSurvey:
    """Accumulates the MCs of a world's vertical lines over rendered images.

    Args:
        line_ids: (L,) landmark ids of the world's vertical lines.
        lines_w: (L, 2) their positions on the floor [m].
        rig: the camera rig the images are rendered with.
    """

    def __init__(self, line_ids: np.ndarray, lines_w: np.ndarray, rig: object) -> None:
        from omnislam.frontend.config import VerticalEdgeConfig

        self.ids = np.asarray(line_ids, dtype=np.int64)
        self.lines_w = np.asarray(lines_w, dtype=float).reshape(-1, 2)
        self.rig = rig
        self.config = VerticalEdgeConfig(enabled=True)
        self.left = np.zeros((self.ids.size, 3))
        self.right = np.zeros((self.ids.size, 3))
        self.count = np.zeros(self.ids.size, dtype=np.int64)

    def add(self, image: np.ndarray, points_w: np.ndarray, wTr: np.ndarray) -> None:
        """One rendered image, its per-pixel world points and the true pose (4, 4)."""
        from scipy.optimize import linear_sum_assignment

        from omnislam.core.se import wrap_angle
        from omnislam.frontend.evaluation import visible_lines
        from omnislam.frontend.vertical_edges import extract_vertical_lines

        if not self.ids.size:
            return
        index, true_b = visible_lines(self.lines_w, wTr, self.rig, points_w)
        if not index.size:
            return
        lines = extract_vertical_lines(image, self.rig, self.config)
        if not len(lines):
            return
        gap = np.abs(wrap_angle(true_b[:, None] - lines.bearings_rad[None, :]))
        cost = np.where(gap <= TOL_RAD, gap, 1e9)
        rows, cols = linear_sum_assignment(cost)
        ok = cost[rows, cols] < 1e9
        for r, c in zip(rows[ok], cols[ok], strict=True):
            k = index[r]
            self.left[k] += lines.means_left[c]
            self.right[k] += lines.means_right[c]
            self.count[k] += 1

    def rows(self) -> np.ndarray:
        """(L, 8) ``id, count, r/g/b left, r/g/b right`` (NaN colours where never seen)."""
        with np.errstate(invalid="ignore", divide="ignore"):
            left = self.left / self.count[:, None]
            right = self.right / self.count[:, None]
        return np.column_stack([self.ids, self.count, left, right])
