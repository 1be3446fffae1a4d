"""Trajectory metrics: absolute trajectory error (ATE) with explicit alignment.

ATE after Sturm, Engelhard, Endres, Burgard, Cremers, "A benchmark for the evaluation of RGB-D
SLAM systems", IROS 2012: associate estimate and ground-truth poses by time stamp, align the
estimate to the ground truth with a rigid (or similarity) transform, and take the RMSE of the
position differences. The least-squares alignment is Umeyama's ("Least-squares estimation of
transformation parameters between two point patterns", IEEE PAMI 13(4), 1991).

Pure numpy; the same numbers as ``evo_ape`` for SE3/SIM3 (tests/compare/test_metrics.py).
"""

from __future__ import annotations

import enum
from dataclasses import dataclass

import numpy as np

from omnislam.core.types import Trajectory
from omnislam.errors import DataError

#: default association tolerance: estimate and ground truth stamps closer than this match [s]
DEFAULT_MAX_DT_S = 0.01

#: ORIGIN alignment against position-only ground truth (GPS) fits the heading on the start of
#: the run: the associated pairs within this much ground-truth travel [m]
ORIGIN_HEADING_BASELINE_M = 20.0


class Alignment(enum.Enum):
    """How an estimate is aligned to the ground truth before ATE is computed."""

    NONE = "none"  # compare in the ground truth frame as is
    ORIGIN = "origin"  # anchor the first pose (start of run only): drift shows fully
    SE2 = "se2"  # best planar rotation (about z) + translation, Umeyama in x-y
    SE3 = "se3"  # best 3-D rotation + translation (Umeyama)
    SIM3 = "sim3"  # SE3 plus scale (Umeyama with scale)


@dataclass(frozen=True, slots=True)
class AteResult:
    """ATE of one estimate against one ground truth.

    Attributes:
        alignment: the alignment used.
        rmse_m, mean_m, median_m, max_m: statistics of the position errors [m].
        errors_m: (M,) position error of each associated pair after alignment [m].
        stamps_s: (M,) estimate stamps of the associated pairs [s].
        matched: M, the number of associated pairs.
        coverage: M / number of estimate poses (GPS gaps lower it).
        gtTest: (4, 4) the aligning transform, ground truth <- estimate (scale in the rotation
            block for SIM3).
        scale: the similarity scale (1 unless SIM3).
    """

    alignment: Alignment
    rmse_m: float
    mean_m: float
    median_m: float
    max_m: float
    errors_m: np.ndarray
    stamps_s: np.ndarray
    matched: int
    coverage: float
    gtTest: np.ndarray
    scale: float = 1.0


def associate(
    estimate_stamps_s: np.ndarray, truth_stamps_s: np.ndarray, max_dt_s: float = DEFAULT_MAX_DT_S
) -> tuple[np.ndarray, np.ndarray]:
    """Pair every estimate stamp with the nearest ground-truth stamp within ``max_dt_s``.

    Args:
        estimate_stamps_s: (N,) increasing stamps.
        truth_stamps_s: (M,) increasing stamps.
        max_dt_s: largest accepted time difference [s].

    Returns:
        (i_estimate (K,), i_truth (K,)) indices of the pairs; each ground-truth pose is used at
        most once (the closest estimate wins).
    """
    est = np.asarray(estimate_stamps_s, dtype=float)
    gt = np.asarray(truth_stamps_s, dtype=float)
    if len(est) == 0 or len(gt) == 0:
        return np.zeros(0, dtype=np.int64), np.zeros(0, dtype=np.int64)
    j = (
        np.clip(np.searchsorted(gt, est), 1, len(gt) - 1)
        if len(gt) > 1
        else np.zeros(len(est), int)
    )
    left = np.maximum(j - 1, 0)
    pick = np.where(np.abs(gt[left] - est) <= np.abs(gt[j] - est), left, j)
    dt = np.abs(gt[pick] - est)
    ok = dt <= max_dt_s
    i_est = np.flatnonzero(ok)
    i_gt = pick[ok]
    # keep the closest estimate per ground-truth pose
    order = np.lexsort((dt[ok], i_gt))
    _, first = np.unique(i_gt[order], return_index=True)
    keep = np.sort(order[first])
    return i_est[keep].astype(np.int64), i_gt[keep].astype(np.int64)


def umeyama(
    source: np.ndarray, target: np.ndarray, with_scale: bool = False
) -> tuple[np.ndarray, np.ndarray, float]:
    """Least-squares R, t, s with ``target ~ s R source + t`` (Umeyama 1991, eqs. 40-42).

    Args:
        source: (N, d) points.
        target: (N, d) corresponding points.
        with_scale: also estimate the scale s (else s = 1).

    Returns:
        (R (d, d) proper rotation, t (d,), s).
    """
    source = np.asarray(source, dtype=float)
    target = np.asarray(target, dtype=float)
    n, d = source.shape
    if n < 2:
        raise DataError(f"alignment needs at least 2 associated poses, got {n}")
    mu_s, mu_t = source.mean(axis=0), target.mean(axis=0)
    xs, xt = source - mu_s, target - mu_t
    covariance = xt.T @ xs / n
    U, D, Vt = np.linalg.svd(covariance)
    S = np.eye(d)
    if np.linalg.det(U) * np.linalg.det(Vt) < 0:
        S[-1, -1] = -1.0
    R = U @ S @ Vt
    scale = float(np.trace(np.diag(D) @ S) / (np.sum(xs**2) / n)) if with_scale else 1.0
    return R, mu_t - scale * R @ mu_s, scale


def ate(
    estimate: Trajectory,
    truth: Trajectory,
    alignment: Alignment = Alignment.SE2,
    *,
    max_dt_s: float = DEFAULT_MAX_DT_S,
    truth_has_orientation: bool = True,
) -> AteResult:
    """Absolute trajectory error (position RMSE after alignment; Sturm et al. 2012).

    Args:
        estimate: estimated poses ``wTr``.
        truth: ground-truth poses, possibly at a subset of the stamps (GPS gaps).
        alignment: how to align (see Alignment). ORIGIN uses the first associated pair's relative
            pose; against position-only truth (``truth_has_orientation=False``, GPS) it fits
            rotation and translation on the pairs within the first ORIGIN_HEADING_BASELINE_M of
            ground-truth travel instead.
        max_dt_s: association tolerance [s].
        truth_has_orientation: False when the truth's rotations are placeholders.

    Returns:
        AteResult.

    Raises:
        DataError: fewer than 2 associated poses.
    """
    i_est, i_gt = associate(estimate.stamps_s, truth.stamps_s, max_dt_s)
    if len(i_est) < 2:
        raise DataError(
            f"only {len(i_est)} estimate poses have ground truth within {max_dt_s} s; "
            "cannot compute ATE"
        )
    p_est = estimate.positions_w[i_est]
    p_gt = truth.positions_w[i_gt]
    T = np.eye(4)
    scale = 1.0
    if alignment is Alignment.SE2:
        R2, t2, _ = umeyama(p_est[:, :2], p_gt[:, :2])
        T[:2, :2], T[:2, 3] = R2, t2
    elif alignment in (Alignment.SE3, Alignment.SIM3):
        R, t, scale = umeyama(p_est, p_gt, with_scale=alignment is Alignment.SIM3)
        T[:3, :3], T[:3, 3] = scale * R, t
    elif alignment is Alignment.ORIGIN:
        if truth_has_orientation:
            T = truth.poses_w[i_gt[0]] @ np.linalg.inv(estimate.poses_w[i_est[0]])
        else:
            travel = np.concatenate(
                [[0.0], np.cumsum(np.linalg.norm(np.diff(p_gt[:, :2], axis=0), axis=1))]
            )
            window = max(int(np.searchsorted(travel, ORIGIN_HEADING_BASELINE_M)), 2)
            R2, t2, _ = umeyama(p_est[:window, :2], p_gt[:window, :2])
            T[:2, :2], T[:2, 3] = R2, t2
    aligned = p_est @ T[:3, :3].T + T[:3, 3]
    errors = np.linalg.norm(aligned - p_gt, axis=1)
    return AteResult(
        alignment=alignment,
        rmse_m=float(np.sqrt(np.mean(errors**2))),
        mean_m=float(np.mean(errors)),
        median_m=float(np.median(errors)),
        max_m=float(np.max(errors)),
        errors_m=errors,
        stamps_s=estimate.stamps_s[i_est],
        matched=len(i_est),
        coverage=len(i_est) / len(estimate),
        gtTest=T,
        scale=scale,
    )
