"""Evaluate one run: every metric of ``compare.metrics`` on a RunRecord, as metrics.json keys.

Which numbers mean what (every number is labelled with the kind of its ground truth; when that
is a reference solution computed by omnislam, ``reference`` names it, e.g. "lm-optimum" for
gtsam's victoria_park.txt, ``compare.reference``):

* ATE (``ate_*``): SE(2)-aligned position RMSE (``alignment``); ``ate_origin_*``: the first pose
  anchored instead (drift shows fully).
* RPE (``rpe_*``): segments of ``rpe_segment_m`` metres of ground-truth travel (all start poses,
  evo's pair rule), SE(2) errors for planar runs; ``rpe_frame_*``: consecutive frames (delta 1);
  ``rpe_by_distance``: the error-over-distance curve (KITTI-like segment lengths).
* Landmarks (``landmark_*``): the estimate's map moved with the SE(2) trajectory alignment
  (or aligned on the landmarks themselves when there is no ground-truth trajectory), then
  matched by id when the sightings carried the true ids, else by optimal assignment within
  ``landmark_gate_m``.
* NEES (``nees_*`` pose, ``landmark_nees_*``): in the estimate's frame with the ORIGIN alignment;
  null when the estimator gives no covariances.
* Timing (TIMING_KEYS of ``rundir``): per-step wall time, total, peak RSS of the run.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from omnislam.compare.metrics import (
    DEFAULT_LANDMARK_GATE_M,
    DEFAULT_RPE_SEGMENT_M,
    Alignment,
    AteResult,
    DeltaUnit,
    LandmarkAssociation,
    accumulated_distances,
    associate,
    ate,
    landmark_error,
    landmark_nees,
    pose_nees,
    rpe,
    segment_lengths,
    timing_stats,
    umeyama,
)
from omnislam.compare.rundir import REQUIRED_METRICS, RunRecord
from omnislam.datasets.sequence import GroundTruthKind
from omnislam.errors import ConfigError

#: how reports name each kind of ground truth, next to every number
GROUND_TRUTH_LABELS: dict[GroundTruthKind, str] = {
    GroundTruthKind.EXACT: "exact ground truth (synthetic)",
    GroundTruthKind.MOTION_CAPTURE: "motion-capture ground truth (Vicon)",
    GroundTruthKind.GPS_PARTIAL: "GPS ground truth (partial, positions only)",
    GroundTruthKind.PSEUDO: "pseudo ground truth (corrected log; not independent)",
    GroundTruthKind.REFERENCE: "reference solution (not independent)",
    GroundTruthKind.NONE: "no ground truth",
}


#: further keys of metrics.json (null when not computable)
OPTIONAL_METRICS = (
    "ate_mean_m",
    "ate_median_m",
    "ate_origin_rmse_m",
    "ate_origin_max_m",
    "ate_matched",
    "ate_coverage",
    "travel_m",
    "rpe_segment_m",
    "rpe_rot_rmse_deg",
    "rpe_pairs",
    "rpe_planar",
    "rpe_frame_trans_rmse_m",
    "rpe_frame_rot_rmse_deg",
    "rpe_by_distance",
    "landmark_median_m",
    "landmark_max_m",
    "landmarks_truth",
    "landmark_duplicates",
    "landmark_spurious",
    "landmarks_missed",
    "landmark_association",
    "landmark_gate_m",
    "anees",
    "nees_dof",
    "nees_within_bounds",
    "nees_count",
    "landmark_nees_mean",
    "landmark_anees",
    "landmark_nees_dof",
    "landmark_nees_count",
)


@dataclass(frozen=True, slots=True)
class EvaluationOptions:
    """Settings of ``evaluate_record`` (stored in metrics.json with the numbers).

    Attributes:
        rpe_segment_m: segment length of ``rpe_trans_rmse_m`` [m].
        landmark_gate_m: association gate for maps without true ids [m].
        curve_lengths: number of segment lengths in ``rpe_by_distance``.
    """

    rpe_segment_m: float = DEFAULT_RPE_SEGMENT_M
    landmark_gate_m: float = DEFAULT_LANDMARK_GATE_M
    curve_lengths: int = 8

    def __post_init__(self) -> None:
        if not self.rpe_segment_m > 0 or not self.landmark_gate_m > 0:
            raise ConfigError("rpe_segment_m and landmark_gate_m must be positive")


def _finite(value: float) -> float | None:
    return float(value) if value is not None and math.isfinite(value) else None


def evaluate_record(record: RunRecord, options: EvaluationOptions) -> dict[str, object]:
    """All metrics of one run against the ground truth stored with it.

    Returns:
        A JSON-ready mapping with REQUIRED_METRICS and the keys described in the module
        docstring; null where a metric cannot be computed (no ground truth, no covariances, no
        landmarks).
    """
    config = record.config
    estimate = record.estimate
    gt = record.ground_truth
    timing = timing_stats(record.step_s)
    out: dict[str, object] = dict.fromkeys(REQUIRED_METRICS)
    out.update(
        {
            "dataset": config.dataset,
            "estimator": config.estimator,
            "seed": config.seed,
            "estimator_options": dict(config.estimator_options),
            "dataset_options": dict(config.dataset_options),
            "ground_truth": gt.kind.value,
            "ground_truth_label": GROUND_TRUTH_LABELS[gt.kind],
            "ground_truth_note": gt.note,
            "reference": config.ground_truth_reference,
            "frames": len(estimate.trajectory),
            "step_ms_median": _finite(timing.median_ms),
            "step_ms_p95": _finite(timing.p95_ms),
            "step_ms_mean": _finite(timing.mean_ms),
            "step_ms_max": _finite(timing.max_ms),
            "total_s": config.total_s,
            "peak_rss_mb": config.peak_rss_mb,
            "landmarks_estimated": len(estimate.landmark_ids),
            "has_pose_covariances": estimate.pose_covariances is not None,
            "has_landmark_covariances": estimate.landmark_covariances is not None,
        }
    )
    for key in OPTIONAL_METRICS:
        out.setdefault(key, None)

    oriented = gt.kind is not GroundTruthKind.GPS_PARTIAL
    se2: AteResult | None = None
    origin: AteResult | None = None
    if gt.trajectory is not None:
        se2 = ate(estimate.trajectory, gt.trajectory, Alignment.SE2, truth_has_orientation=oriented)
        origin = ate(
            estimate.trajectory, gt.trajectory, Alignment.ORIGIN, truth_has_orientation=oriented
        )
        out.update(
            {
                "ate_rmse_m": se2.rmse_m,
                "ate_max_m": se2.max_m,
                "ate_mean_m": se2.mean_m,
                "ate_median_m": se2.median_m,
                "alignment": Alignment.SE2.value,
                "ate_origin_rmse_m": origin.rmse_m,
                "ate_origin_max_m": origin.max_m,
                "ate_matched": se2.matched,
                "ate_coverage": se2.coverage,
            }
        )
        out.update(_rpe_metrics(record, options, oriented))
        if estimate.pose_covariances is not None:
            result = pose_nees(
                estimate.trajectory,
                estimate.pose_covariances,
                gt.trajectory,
                truth_has_orientation=oriented,
            )
            out.update(
                {
                    "nees_mean": _finite(result.mean),
                    "anees": _finite(result.anees),
                    "nees_dof": result.dof,
                    "nees_within_bounds": _finite(result.within_bounds),
                    "nees_count": len(result.values),
                }
            )
    if len(gt.landmark_ids):
        out.update(_landmark_metrics(record, options, se2, origin))
    return out


def _rpe_metrics(
    record: RunRecord, options: EvaluationOptions, oriented: bool
) -> dict[str, object]:
    """RPE at the segment length, per frame, and over distance."""
    estimate, truth = record.estimate.trajectory, record.ground_truth.trajectory
    assert truth is not None
    _, i_gt = associate(estimate.stamps_s, truth.stamps_s)
    travel = float(accumulated_distances(truth.positions_w[i_gt])[-1])
    main = rpe(
        estimate, truth, options.rpe_segment_m, DeltaUnit.METERS, truth_has_orientation=oriented
    )
    frame = rpe(estimate, truth, 1, DeltaUnit.FRAMES, truth_has_orientation=oriented)
    curve = []
    for length in segment_lengths(travel, options.curve_lengths):
        r = rpe(estimate, truth, length, DeltaUnit.METERS, truth_has_orientation=oriented)
        if r.count:
            curve.append(
                {
                    "length_m": length,
                    "trans_rmse_m": r.trans_rmse_m,
                    "rot_rmse_deg": _finite(math.degrees(r.rot_rmse_rad)),
                    "pairs": r.count,
                }
            )
    return {
        "travel_m": travel,
        "rpe_segment_m": options.rpe_segment_m,
        "rpe_trans_rmse_m": _finite(main.trans_rmse_m),
        "rpe_rot_rmse_deg": _finite(math.degrees(main.rot_rmse_rad)),
        "rpe_pairs": main.count,
        "rpe_planar": main.planar,
        "rpe_frame_trans_rmse_m": _finite(frame.trans_rmse_m),
        "rpe_frame_rot_rmse_deg": _finite(math.degrees(frame.rot_rmse_rad)),
        "rpe_by_distance": curve,
    }


def _landmark_metrics(
    record: RunRecord,
    options: EvaluationOptions,
    se2: AteResult | None,
    origin: AteResult | None,
) -> dict[str, object]:
    """Landmark error and landmark NEES."""
    estimate, gt = record.estimate, record.ground_truth
    by_id = record.config.landmark_ids_from_truth
    association = LandmarkAssociation.BY_ID if by_id else LandmarkAssociation.ASSIGNMENT
    out: dict[str, object] = {
        "landmarks_truth": len(gt.landmark_ids),
        "landmark_association": association.value,
        "landmark_gate_m": None if by_id else options.landmark_gate_m,
    }
    if not len(estimate.landmark_ids):
        out.update(
            {
                "landmarks_matched": 0,
                "landmarks_missed": len(gt.landmark_ids),
                "landmark_duplicates": 0,
                "landmark_spurious": 0,
            }
        )
        return out
    gtTest = se2.gtTest if se2 is not None else None
    anchor = origin.gtTest if origin is not None else None
    if gtTest is None and by_id:  # no trajectory truth: align the maps on the shared ids
        _, i_e, i_g = np.intersect1d(estimate.landmark_ids, gt.landmark_ids, return_indices=True)
        if len(i_e) >= 2:
            R2, t2, _ = umeyama(estimate.landmarks_w[i_e, :2], gt.landmarks_w[i_g, :2])
            gtTest = np.eye(4)
            gtTest[:2, :2], gtTest[:2, 3] = R2, t2
            anchor = gtTest
    if gtTest is None:
        return out  # nothing relates the two frames
    result = landmark_error(
        estimate.landmark_ids,
        estimate.landmarks_w,
        gt.landmark_ids,
        gt.landmarks_w,
        gtTest,
        association,
        options.landmark_gate_m,
    )
    out.update(
        {
            "landmark_rmse_m": _finite(result.rmse_m),
            "landmark_median_m": _finite(result.median_m),
            "landmark_max_m": _finite(result.max_m),
            "landmarks_matched": result.matched,
            "landmarks_missed": result.missed,
            "landmark_duplicates": result.duplicates,
            "landmark_spurious": result.spurious,
        }
    )
    if estimate.landmark_covariances is not None and result.matched and anchor is not None:
        nees = landmark_nees(
            estimate.landmarks_w[result.i_estimate],
            estimate.landmark_covariances[result.i_estimate],
            gt.landmarks_w[result.i_truth],
            anchor,
            result.planar,
        )
        out.update(
            {
                "landmark_nees_mean": _finite(nees.mean),
                "landmark_anees": _finite(nees.anees),
                "landmark_nees_dof": nees.dof,
                "landmark_nees_count": len(nees.values),
            }
        )
    return out
