"""Consistency: the normalised estimation error squared (NEES) of poses and landmarks.

An estimator is consistent when its errors are as large as its own covariances say: the NEES of
a state, ``e^T P^-1 e``, then averages its dimension (Bar-Shalom, Li, Kirubarajan 2001, sec.
5.4.2). Errors are taken in the estimate's frame, the ground truth moved there by the ORIGIN
alignment (the first pose anchored, as the estimators anchor it).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from omnislam.core.types import Trajectory
from omnislam.metrics.trajectory import DEFAULT_MAX_DT_S, Alignment, associate, ate

#: probability of the chi-square acceptance interval reported with NEES
NEES_CONFIDENCE = 0.95
#: a median NEES above this many times its degrees of freedom is shown as "inconsistent", not as
#: a number: the covariance understates the error by more than an order of magnitude in standard
#: deviation, and values like 1e44 (a collapsed covariance) carry no further meaning
INCONSISTENT_FACTOR = 100.0


@dataclass(frozen=True, slots=True)
class NeesResult:
    """Normalised estimation error squared (Bar-Shalom, Li, Kirubarajan 2001, sec. 5.4.2).

    ``NEES_k = e_k^T P_k^-1 e_k`` with ``e_k`` the error of state k and ``P_k`` its estimated
    covariance; a consistent estimator has ``E[NEES] = dof``. ANEES = mean NEES / dof (1 when
    consistent).

    Attributes:
        dof: dimension of the error (3 for [x, y, yaw], 2 for x-y).
        values: (K,) NEES of every state with a usable (positive definite) covariance.
        mean: mean NEES (NaN when K = 0).
        median: median NEES (NaN when K = 0): robust to the few steps where a covariance
            collapses, which dominate the mean.
        anees: mean / dof.
        within_bounds: fraction of ``values`` inside the two-sided NEES_CONFIDENCE chi-square
            interval of ``dof`` degrees of freedom.
        skipped: states whose covariance was not positive definite.
    """

    dof: int
    values: np.ndarray
    mean: float
    median: float
    anees: float
    within_bounds: float
    skipped: int


def nees(errors: np.ndarray, covariances: np.ndarray) -> NeesResult:
    """NEES of (K, d) errors with (K, d, d) covariances (non positive definite ones skipped)."""
    from scipy.stats import chi2

    errors = np.asarray(errors, dtype=float)
    covariances = np.asarray(covariances, dtype=float)
    k, dof = errors.shape if errors.ndim == 2 else (0, covariances.shape[-1])
    values = np.zeros(0)
    skipped = 0
    if k:
        sym = 0.5 * (covariances + np.swapaxes(covariances, 1, 2))
        eigen = np.linalg.eigvalsh(sym)
        scale = np.maximum(np.abs(eigen).max(axis=1), np.finfo(float).tiny)
        good = eigen.min(axis=1) > 1e-12 * scale
        skipped = int(k - np.count_nonzero(good))
        solved = np.linalg.solve(sym[good], errors[good][:, :, None])[:, :, 0]
        values = np.einsum("ki,ki->k", errors[good], solved)
    lo, hi = chi2.ppf([(1 - NEES_CONFIDENCE) / 2, (1 + NEES_CONFIDENCE) / 2], dof)
    has = len(values) > 0
    mean = float(values.mean()) if has else math.nan
    return NeesResult(
        dof=int(dof),
        values=values,
        mean=mean,
        median=float(np.median(values)) if has else math.nan,
        anees=mean / dof if has else math.nan,
        within_bounds=float(np.mean((values >= lo) & (values <= hi))) if has else math.nan,
        skipped=skipped,
    )


def to_estimate_frame(gtTest: np.ndarray, xyt_truth: np.ndarray) -> np.ndarray:
    """Planar poses (N, 3) of the ground truth expressed in the estimate's world frame.

    ``gtTest`` maps estimate-world to truth-world (rigid); the result is ``gtTest^-1 * wTr``.
    """
    R = gtTest[:2, :2]
    yaw = math.atan2(R[1, 0], R[0, 0])
    xy = (np.asarray(xyt_truth)[:, :2] - gtTest[:2, 3]) @ R
    return np.column_stack([xy, np.asarray(xyt_truth)[:, 2] - yaw])


def pose_nees(
    estimate: Trajectory,
    pose_covariances: np.ndarray,
    truth: Trajectory,
    *,
    max_dt_s: float = DEFAULT_MAX_DT_S,
    truth_has_orientation: bool = True,
) -> NeesResult:
    """Pose NEES on [x, y, yaw] (yaw residual wrapped), in the estimate's frame.

    The ground truth is moved into the estimate's frame with the ORIGIN alignment (the first
    pose anchored, as the estimators anchor it), so the covariance that grows from the start is
    compared with the error that grows from the start. Against position-only truth (GPS) the
    NEES is on [x, y] (dof 2).

    Args:
        estimate: estimated poses.
        pose_covariances: (N, 3, 3) covariances of [x, y, yaw] per estimated pose.
        truth: ground-truth poses.
        max_dt_s: association tolerance [s].
        truth_has_orientation: False for position-only truth.

    Returns:
        NeesResult.
    """
    origin = ate(
        estimate,
        truth,
        Alignment.ORIGIN,
        max_dt_s=max_dt_s,
        truth_has_orientation=truth_has_orientation,
    )
    i_est, i_gt = associate(estimate.stamps_s, truth.stamps_s, max_dt_s)
    gt_e = to_estimate_frame(origin.gtTest, truth.se2[i_gt])
    est = estimate.se2[i_est]
    err = est - gt_e
    err[:, 2] = np.arctan2(np.sin(err[:, 2]), np.cos(err[:, 2]))
    cov = np.asarray(pose_covariances, dtype=float)[i_est]
    if not truth_has_orientation:
        return nees(err[:, :2], cov[:, :2, :2])
    return nees(err, cov)


def landmark_nees(
    estimate_w: np.ndarray,
    covariances: np.ndarray,
    truth_w: np.ndarray,
    gtTest: np.ndarray,
    planar: bool,
) -> NeesResult:
    """Landmark NEES of matched pairs, in the estimate's frame.

    Args:
        estimate_w: (K, 3) matched estimated landmarks (estimate's frame) [m].
        covariances: (K, 3, 3) their covariances [m^2].
        truth_w: (K, 3) the matched true landmarks (truth's frame) [m].
        gtTest: rigid transform truth <- estimate (ORIGIN alignment).
        planar: x-y only (dof 2), else 3-D (dof 3).
    """
    R, t = gtTest[:3, :3], gtTest[:3, 3]
    truth_e = (np.asarray(truth_w, dtype=float).reshape(-1, 3) - t) @ R
    err = np.asarray(estimate_w, dtype=float).reshape(-1, 3) - truth_e
    cov = np.asarray(covariances, dtype=float).reshape(-1, 3, 3)
    if planar:
        return nees(err[:, :2], cov[:, :2, :2])
    return nees(err, cov)
