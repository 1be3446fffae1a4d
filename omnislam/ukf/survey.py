"""The ground truth of the association: which landmark an extracted line is the image of.

Seen from the true pose (the renderer's ground truth, never the localiser's input), each
extracted line is labelled with the visible landmark that projects nearest to it, within
``tol_px``, one to one (``label_lines``). Benchmarks count wrong pairs with it. (A synthetic
world's MC descriptors are surveyed while rendering: ``datasets.synthetic.line_survey``.)
"""

from __future__ import annotations

import numpy as np

from omnislam.core.types import PriorMap
from omnislam.ukf.candidates import select_candidates
from omnislam.ukf.image_line import ImageLine


def label_lines(
    wTr: np.ndarray,
    bearings_rad: np.ndarray,
    prior_map: PriorMap,
    image_line: ImageLine,
    tol_px: float = 2.0,
    max_range_m: float = 50.0,
) -> np.ndarray:
    """The landmark id each line is the image of, seen from the true pose (-1: none).

    A line takes the visible landmark whose projection is nearest, if within ``tol_px``;
    a landmark goes to its nearest line only (one-to-one, greedy by distance).
    """
    from scipy.optimize import linear_sum_assignment

    use = (
        prior_map.vertical_line if prior_map.vertical_line.any() else np.ones(len(prior_map), bool)
    )
    ids = prior_map.landmark_ids[use]
    cands = select_candidates(
        wTr, prior_map.points_w[use, :2], prior_map.walls_w, image_line, max_range_m, 0.05
    )
    out = np.full(len(bearings_rad), -1, dtype=np.int64)
    if not len(cands) or not len(bearings_rad):
        return out
    u = image_line.u_px(bearings_rad)
    d = np.abs(u[:, None] - cands.u_px[None, :])
    d = np.where(np.isfinite(d) & (d <= tol_px), d, 1e9)
    rows, cols = linear_sum_assignment(d)
    ok = d[rows, cols] < 1e9
    out[rows[ok]] = ids[cands.index[cols[ok]]]
    return out
