"""Colour descriptors (MC) of a map's vertical lines, surveyed from frames at known poses.

Barra & Costa's map stores, for each landmark, its MC (sec. 2.2), measured beforehand. A
synthetic world or a surveyed map has the positions but not the colours; this module plays the
surveyor: with poses known (the renderer's ground truth, never the localiser's input), each
extracted line is labelled with the landmark that projects nearest to it, within ``tol_px``,
and one-to-one (``label_lines``), and a landmark's MC is the mean of its lines' MCs. The same
labelling gives the ground truth of the association for benchmarks.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace

import numpy as np

from omnislam.core.types import FrameInput, PriorMap
from omnislam.ukf.candidates import select_candidates
from omnislam.ukf.image_line import ImageLine
from omnislam.ukf.photometric import mc_from_pmc


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


def survey_descriptors(
    prior_map: PriorMap,
    frames: Sequence[FrameInput],
    poses_w: np.ndarray,
    image_line: ImageLine,
    tol_px: float = 2.0,
) -> PriorMap:
    """``prior_map`` with means_left / means_right averaged over the frames' labelled lines.

    Args:
        frames: frames with ``vertical_lines`` (others are skipped).
        poses_w: (N, 3) true pose of every frame (indexed by ``FrameInput.index``).

    Returns:
        A PriorMap whose MC rows are NaN for landmarks never labelled.
    """
    m = len(prior_map)
    row = {int(i): k for k, i in enumerate(prior_map.landmark_ids)}
    total_l = np.zeros((m, 3))
    total_r = np.zeros((m, 3))
    count = np.zeros(m)
    for frame in frames:
        lines = frame.vertical_lines
        if lines is None or not len(lines):
            continue
        labels = label_lines(
            poses_w[frame.index], lines.bearings_rad, prior_map, image_line, tol_px
        )
        left, right = mc_from_pmc(lines.profiles)
        for k in np.flatnonzero(labels >= 0):
            r = row[int(labels[k])]
            total_l[r] += left[k]
            total_r[r] += right[k]
            count[r] += 1
    with np.errstate(invalid="ignore", divide="ignore"):
        means_left = total_l / count[:, None]
        means_right = total_r / count[:, None]
    return replace(
        prior_map,
        source=f"{prior_map.source} + MC surveyed from {int((count > 0).sum())} landmarks",
        means_left=means_left,
        means_right=means_right,
    )
