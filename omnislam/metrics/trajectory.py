"""Trajectory metrics: absolute trajectory error (ATE) with explicit alignment, and the RPE.

ATE after Sturm, Engelhard, Endres, Burgard, Cremers, "A benchmark for the evaluation of RGB-D
SLAM systems", IROS 2012: associate estimate and ground-truth poses by time stamp, align the
estimate to the ground truth with a rigid (or similarity) transform, and take the RMSE of the
position differences. The least-squares alignment is Umeyama's ("Least-squares estimation of
transformation parameters between two point patterns", IEEE PAMI 13(4), 1991).

Pure numpy; the same numbers as ``evo_ape`` for SE3/SIM3 (tests/metrics/test_trajectory.py).
"""

from __future__ import annotations

import enum
import math
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


# --------------------------------------------------------------------------------------------
# Relative pose error (RPE)
# --------------------------------------------------------------------------------------------

#: default RPE segment length for ``rpe_trans_rmse_m`` [m] (of runs long enough for it)
DEFAULT_RPE_SEGMENT_M = 10.0
#: a run is long enough for the default segment when it travels this many segments
SHORT_RUN_SEGMENTS = 4.0
#: the shortest segment chosen automatically [m]
MIN_AUTO_SEGMENT_M = 0.01
#: a pair i, j is accepted when its ground-truth travel is within this fraction of the segment
#: length (evo's ``rel_delta_tol``)
DEFAULT_RPE_REL_TOL = 0.1
#: trajectories whose z, roll and pitch stay within this of zero are treated as planar
PLANAR_TOL = 1e-9


class DeltaUnit(enum.Enum):
    """What the RPE segment length counts (evo's ``Unit.frames`` / ``Unit.meters``)."""

    FRAMES = "frames"
    METERS = "meters"


@dataclass(frozen=True, slots=True)
class RpeResult:
    """Relative pose error over segments of one length.

    For a pair (i, j) of associated poses the error is ``E = (gTi^-1 gTj)^-1 (eTi^-1 eTj)``
    (Sturm et al. 2012 eq. 2; evo's ``RPE`` with ``pairs_from_reference``); its translation norm
    and rotation angle are the per-pair errors. Planar runs use SE(2) (x, y, yaw), others SE(3).

    Attributes:
        delta: the segment length, in ``unit``.
        unit: frames or metres of ground-truth travel.
        planar: True when computed in SE(2).
        pairs: (K, 2) indices into the *associated* poses of every pair used.
        trans_errors_m: (K,) translation error of each pair [m].
        rot_errors_rad: (K,) rotation error of each pair [rad]; None when the ground truth has
            no orientation (then the translation error is the world-frame displacement error
            after the global SE(2) alignment).
        trans_rmse_m: RMSE of ``trans_errors_m`` [m] (NaN when no pair).
        rot_rmse_rad: RMSE of ``rot_errors_rad`` [rad] (NaN when no pair or no orientation).
    """

    delta: float
    unit: DeltaUnit
    planar: bool
    pairs: np.ndarray
    trans_errors_m: np.ndarray
    rot_errors_rad: np.ndarray | None
    trans_rmse_m: float
    rot_rmse_rad: float

    @property
    def count(self) -> int:
        """Number of pairs."""
        return int(self.pairs.shape[0])


def accumulated_distances(positions: np.ndarray) -> np.ndarray:
    """(N,) travelled distance from the first position [m] (N, d) -> (N,)."""
    positions = np.asarray(positions, dtype=float)
    if len(positions) == 0:
        return np.zeros(0)
    steps = np.linalg.norm(positions[:-1] - positions[1:], axis=1)
    return np.concatenate(([0.0], np.cumsum(steps)))


def pairs_by_frames(n: int, delta: int, all_pairs: bool = True) -> np.ndarray:
    """Index pairs (i, i + delta): every i (``all_pairs``) or i = 0, delta, 2 delta, ... (K, 2)."""
    if delta < 1:
        raise DataError(f"RPE delta must be at least 1 frame, got {delta}")
    starts = np.arange(0, n - delta) if all_pairs else np.arange(0, n - delta, delta)
    return np.column_stack([starts, starts + delta]).astype(np.int64).reshape(-1, 2)


def pairs_by_distance(
    positions: np.ndarray, delta_m: float, rel_tol: float = DEFAULT_RPE_REL_TOL
) -> np.ndarray:
    """Pairs (i, j > i) whose travelled distance is closest to ``delta_m`` (all start poses).

    For each i, j minimises ``|(d_j - d_i) - delta_m|`` over j > i (the first such j on ties)
    and the pair is kept when that is at most ``rel_tol * delta_m``; ``d`` is the accumulated
    travel of ``positions``. This is evo's ``filter_pairs_by_path(all_pairs=True)``, vectorised.

    Args:
        positions: (N, d) positions of the reference (ground truth) [m].
        delta_m: segment length [m], > 0.
        rel_tol: accepted relative deviation of the segment length.

    Returns:
        (K, 2) int64 index pairs.
    """
    if not delta_m > 0:
        raise DataError(f"RPE segment length must be positive, got {delta_m}")
    d = accumulated_distances(positions)
    n = len(d)
    if n < 2:
        return np.zeros((0, 2), dtype=np.int64)
    i = np.arange(n - 1)
    lo = i + 1
    above = np.searchsorted(d, d[i] + delta_m, side="left")
    above = np.maximum(above, lo)
    has_above = above < n
    above_c = np.minimum(above, n - 1)
    below = above - 1  # the last index short of the target (n - 1 when none reaches it)
    has_below = below >= lo
    below_c = np.clip(below, lo, n - 1)
    # the first index holding the same distance as the below candidate (argmin's first hit)
    below_first = np.maximum(np.searchsorted(d, d[below_c], side="left"), lo)
    err_above = np.where(has_above, np.abs((d[above_c] - d[i]) - delta_m), np.inf)
    err_below = np.where(has_below, np.abs((d[below_first] - d[i]) - delta_m), np.inf)
    # on equal error the earlier (below) index wins
    take_below = err_below <= err_above
    # equal distances above the target: the first of them
    above_first = np.maximum(np.searchsorted(d, d[above_c], side="left"), lo)
    j = np.where(take_below, below_first, above_first)
    err = np.minimum(err_below, err_above)
    keep = err <= rel_tol * delta_m
    return np.column_stack([i[keep], j[keep]]).astype(np.int64).reshape(-1, 2)


def is_planar(trajectory: Trajectory, tol: float = PLANAR_TOL) -> bool:
    """True when every pose has z = 0 and no roll or pitch (within ``tol``)."""
    poses = trajectory.poses_w
    return bool(
        np.all(np.abs(poses[:, 2, 3]) <= tol) and np.all(np.abs(poses[:, 2, 2] - 1.0) <= tol)
    )


def _relative_se2(xyt_a: np.ndarray, xyt_b: np.ndarray) -> np.ndarray:
    """aTb = a^-1 b for planar poses (K, 3)."""
    c, s = np.cos(xyt_a[:, 2]), np.sin(xyt_a[:, 2])
    dx, dy = xyt_b[:, 0] - xyt_a[:, 0], xyt_b[:, 1] - xyt_a[:, 1]
    dtheta = np.arctan2(np.sin(xyt_b[:, 2] - xyt_a[:, 2]), np.cos(xyt_b[:, 2] - xyt_a[:, 2]))
    return np.column_stack([c * dx + s * dy, -s * dx + c * dy, dtheta])


def _rotation_angle(R: np.ndarray) -> np.ndarray:
    """Angle [rad] of (K, 3, 3) rotation matrices (robust near 0 and pi)."""
    from scipy.spatial.transform import Rotation

    return np.linalg.norm(Rotation.from_matrix(R).as_rotvec(), axis=1)


def rpe(
    estimate: Trajectory,
    truth: Trajectory,
    delta: float = DEFAULT_RPE_SEGMENT_M,
    unit: DeltaUnit = DeltaUnit.METERS,
    *,
    all_pairs: bool = True,
    rel_tol: float = DEFAULT_RPE_REL_TOL,
    planar: bool | None = None,
    max_dt_s: float = DEFAULT_MAX_DT_S,
    truth_has_orientation: bool = True,
) -> RpeResult:
    """Relative pose error over segments (Sturm et al. 2012; KITTI's error over distance).

    Poses are associated by stamp first; pairs are chosen on the associated ground truth
    (``pairs_by_distance`` in metres of travel, ``pairs_by_frames`` in frames).

    Args:
        estimate: estimated poses ``wTr``.
        truth: ground-truth poses.
        delta: segment length (metres or frames).
        unit: DeltaUnit.
        all_pairs: every start pose (overlapping segments); else consecutive segments (frames
            only; in metres all start poses are always used).
        rel_tol: accepted relative deviation of a segment's ground-truth travel (metres).
        planar: SE(2) errors; None = planar when both trajectories are (``is_planar``).
        max_dt_s: association tolerance [s].
        truth_has_orientation: False for position-only truth (GPS): the translation error is
            ``R (pe_j - pe_i) - (pg_j - pg_i)`` with R the global SE(2) alignment rotation, and
            there is no rotation error.

    Returns:
        RpeResult (no pairs -> NaN RMSE).
    """
    i_est, i_gt = associate(estimate.stamps_s, truth.stamps_s, max_dt_s)
    if len(i_est) < 2:
        raise DataError(
            f"only {len(i_est)} estimate poses have ground truth within {max_dt_s} s; "
            "cannot compute RPE"
        )
    est_T = estimate.poses_w[i_est]
    gt_T = truth.poses_w[i_gt]
    if planar is None:
        planar = is_planar(estimate) and is_planar(truth)
    if unit is DeltaUnit.FRAMES:
        if float(delta) != int(delta):
            raise DataError(f"RPE delta in frames must be an integer, got {delta}")
        pairs = pairs_by_frames(len(i_est), int(delta), all_pairs)
    else:
        gt_xyz = gt_T[:, :3, 3] if not planar else gt_T[:, :2, 3]
        pairs = pairs_by_distance(gt_xyz, float(delta), rel_tol)
    a, b = pairs[:, 0], pairs[:, 1]
    rot: np.ndarray | None
    if not truth_has_orientation:
        R2, _, _ = umeyama(est_T[:, :2, 3], gt_T[:, :2, 3])
        d_est = (est_T[b, :2, 3] - est_T[a, :2, 3]) @ R2.T
        d_gt = gt_T[b, :2, 3] - gt_T[a, :2, 3]
        trans = np.linalg.norm(d_est - d_gt, axis=1)
        rot = None
    elif planar:
        est_xyt = se2_from_se3_array(est_T)
        gt_xyt = se2_from_se3_array(gt_T)
        rel_e = _relative_se2(est_xyt[a], est_xyt[b])
        rel_g = _relative_se2(gt_xyt[a], gt_xyt[b])
        err = _relative_se2(rel_g, rel_e)
        trans = np.linalg.norm(err[:, :2], axis=1)
        rot = np.abs(err[:, 2])
    else:
        rel_e = np.linalg.inv(est_T[a]) @ est_T[b]
        rel_g = np.linalg.inv(gt_T[a]) @ gt_T[b]
        err = np.linalg.inv(rel_g) @ rel_e
        trans = np.linalg.norm(err[:, :3, 3], axis=1)
        rot = _rotation_angle(err[:, :3, :3]) if len(err) else np.zeros(0)

    def rmse(x: np.ndarray | None) -> float:
        return float(np.sqrt(np.mean(x**2))) if x is not None and len(x) else math.nan

    return RpeResult(
        delta=float(delta),
        unit=unit,
        planar=bool(planar),
        pairs=pairs,
        trans_errors_m=trans,
        rot_errors_rad=rot,
        trans_rmse_m=rmse(trans),
        rot_rmse_rad=rmse(rot),
    )


def se2_from_se3_array(poses_w: np.ndarray) -> np.ndarray:
    """(N, 4, 4) -> (N, 3) [x, y, yaw] (yaw from the rotation's first column)."""
    poses_w = np.asarray(poses_w, dtype=float)
    return np.column_stack(
        [poses_w[:, 0, 3], poses_w[:, 1, 3], np.arctan2(poses_w[:, 1, 0], poses_w[:, 0, 0])]
    )


def auto_rpe_segment_m(travel_m: float) -> float:
    """The RPE segment length of a run that travels ``travel_m`` metres of ground truth.

    DEFAULT_RPE_SEGMENT_M (10 m) when the run travels at least SHORT_RUN_SEGMENTS (4) times
    that; a shorter run gets the longest 1-2-5 x 10^k length up to a quarter of its travel
    (a 12 m room tour: 2 m), so that three quarters of its poses start a segment instead of
    none; at least MIN_AUTO_SEGMENT_M.
    """
    if not math.isfinite(travel_m) or travel_m >= SHORT_RUN_SEGMENTS * DEFAULT_RPE_SEGMENT_M:
        return DEFAULT_RPE_SEGMENT_M
    limit = travel_m / SHORT_RUN_SEGMENTS
    best = MIN_AUTO_SEGMENT_M
    for exponent in range(-2, 2):
        for mantissa in (1.0, 2.0, 5.0):
            length = mantissa * 10.0**exponent
            if length <= limit * (1 + 1e-12):
                best = max(best, length)
    return best


def segment_lengths(total_travel_m: float, count: int = 8) -> tuple[float, ...]:
    """KITTI-like segment lengths for an error-over-distance curve of a run [m].

    Lengths 1-2-5 x 10^k from 1 m up to half the travelled distance, at most ``count`` of them
    (the longest kept).
    """
    out = []
    for exponent in range(0, 6):
        for mantissa in (1.0, 2.0, 5.0):
            length = mantissa * 10.0**exponent
            if length <= total_travel_m / 2.0:
                out.append(length)
    return tuple(out[-count:])


def translational_drift(
    estimate: Trajectory, truth: Trajectory, segment_m: float = 10.0
) -> tuple[float, float]:
    """Drift as a fraction of the distance travelled: (fraction, segment length used [m]).

    The mean translation error of the relative motion over every segment of ``segment_m`` of
    true travel (half the route when it is shorter), divided by the segment length: KITTI's
    translational error for one segment length, from ``rpe`` in metres. NaN when no segment fits.
    """
    travel = accumulated_distances(truth.positions_w)
    total = float(travel[-1]) if travel.size else 0.0
    segment = min(segment_m, total / 2.0)
    if not segment > 0:
        return float("nan"), segment
    errors = rpe(estimate, truth, segment, DeltaUnit.METERS).trans_errors_m
    return (float(np.mean(errors)) / segment if errors.size else float("nan")), segment
