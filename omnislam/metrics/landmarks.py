"""Landmark map error: the estimated map against the true one, after the trajectory's alignment.

Estimated and true landmarks are matched by id when the sightings carried the true ids, else by
optimal assignment (Hungarian, ``scipy.optimize.linear_sum_assignment``) on the distances of the
aligned maps within a gate; the unmatched are counted as duplicates (within the gate of a
matched true landmark), spurious or missed.
"""

from __future__ import annotations

import enum
import math
from dataclasses import dataclass

import numpy as np

#: default association gate of estimated to true landmarks without ids [m]
DEFAULT_LANDMARK_GATE_M = 2.0


class LandmarkAssociation(enum.Enum):
    """How estimated landmarks are matched to the true ones."""

    BY_ID = "id"  # the estimate's ids are the ground truth's ids
    ASSIGNMENT = "assignment"  # optimal assignment on distance within a gate (Hungarian)


@dataclass(frozen=True, slots=True)
class LandmarkResult:
    """Landmark map error after alignment.

    Attributes:
        association: how the maps were matched.
        gate_m: the gate (ASSIGNMENT) [m]; NaN for BY_ID.
        planar: distances in x-y only (2-D maps).
        estimated: number of estimated landmarks.
        truth: number of true landmarks.
        matched: pairs matched.
        i_estimate, i_truth: (K,) indices of the matched pairs.
        errors_m: (K,) distance of each matched pair after alignment [m].
        rmse_m, median_m, max_m: statistics of ``errors_m`` (NaN when nothing matched).
        duplicates: unmatched estimated landmarks lying within the gate of a matched true
            landmark (the map holds it twice); BY_ID: estimated ids repeated (always 0).
        spurious: unmatched estimated landmarks with no true landmark in the gate (BY_ID:
            estimated ids the ground truth does not have).
        missed: true landmarks nobody matched.
    """

    association: LandmarkAssociation
    gate_m: float
    planar: bool
    estimated: int
    truth: int
    matched: int
    i_estimate: np.ndarray
    i_truth: np.ndarray
    errors_m: np.ndarray
    rmse_m: float
    median_m: float
    max_m: float
    duplicates: int
    spurious: int
    missed: int


def transform_points(T: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Apply a (4, 4) (similarity) transform to (N, 3) points."""
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    return points @ T[:3, :3].T + T[:3, 3]


def landmark_error(
    estimate_ids: np.ndarray,
    estimate_w: np.ndarray,
    truth_ids: np.ndarray,
    truth_w: np.ndarray,
    gtTest: np.ndarray | None = None,
    association: LandmarkAssociation = LandmarkAssociation.ASSIGNMENT,
    gate_m: float = DEFAULT_LANDMARK_GATE_M,
    planar: bool | None = None,
) -> LandmarkResult:
    """Error of an estimated landmark map against the true one.

    Args:
        estimate_ids: (M,) estimated landmark ids.
        estimate_w: (M, 3) estimated positions in the estimate's world frame [m].
        truth_ids: (L,) true ids.
        truth_w: (L, 3) true positions [m].
        gtTest: (4, 4) transform ground truth <- estimate (e.g. ``AteResult.gtTest``); identity
            when None.
        association: BY_ID or ASSIGNMENT (``scipy.optimize.linear_sum_assignment`` on the
            distances of the aligned maps, pairs farther than ``gate_m`` rejected).
        gate_m: association gate [m] (ASSIGNMENT; also what counts as a duplicate).
        planar: compare x-y only; None = when either map has all z = 0.

    Returns:
        LandmarkResult.
    """
    from scipy.optimize import linear_sum_assignment

    est_ids = np.asarray(estimate_ids, dtype=np.int64).reshape(-1)
    gt_ids = np.asarray(truth_ids, dtype=np.int64).reshape(-1)
    T = np.eye(4) if gtTest is None else np.asarray(gtTest, dtype=float)
    est = transform_points(T, estimate_w)
    gt = np.asarray(truth_w, dtype=float).reshape(-1, 3)
    if planar is None:
        planar = bool(
            (len(est) and np.all(np.asarray(estimate_w)[:, 2] == 0))
            or (len(gt) and np.all(gt[:, 2] == 0))
        )
    dims = slice(0, 2) if planar else slice(0, 3)
    duplicates = spurious = 0
    if association is LandmarkAssociation.BY_ID:
        common, i_est, i_gt = np.intersect1d(est_ids, gt_ids, return_indices=True)
        spurious = int(len(est_ids) - len(common))
        gate = math.nan
    else:
        gate = float(gate_m)
        if len(est) and len(gt):
            distance = np.linalg.norm(est[:, None, dims] - gt[None, :, dims], axis=2)
            big = 1e6 * (1.0 + float(distance.max()))
            rows, cols = linear_sum_assignment(np.where(distance <= gate, distance, big))
            ok = distance[rows, cols] <= gate
            i_est, i_gt = rows[ok], cols[ok]
            unmatched = np.setdiff1d(np.arange(len(est)), i_est)
            near = distance[unmatched] <= gate
            near_matched = near[:, i_gt] if len(i_gt) else np.zeros((len(unmatched), 0), bool)
            duplicates = int(np.count_nonzero(near_matched.any(axis=1)))
            spurious = int(len(unmatched) - duplicates)
        else:
            i_est = i_gt = np.zeros(0, dtype=np.int64)
            spurious = len(est)
    errors = np.linalg.norm(est[i_est, dims] - gt[i_gt, dims], axis=1)
    has = len(errors) > 0
    return LandmarkResult(
        association=association,
        gate_m=gate,
        planar=bool(planar),
        estimated=len(est),
        truth=len(gt),
        matched=len(errors),
        i_estimate=np.asarray(i_est, dtype=np.int64),
        i_truth=np.asarray(i_gt, dtype=np.int64),
        errors_m=errors,
        rmse_m=float(np.sqrt(np.mean(errors**2))) if has else math.nan,
        median_m=float(np.median(errors)) if has else math.nan,
        max_m=float(np.max(errors)) if has else math.nan,
        duplicates=duplicates,
        spurious=spurious,
        missed=int(len(gt) - len(errors)),
    )
