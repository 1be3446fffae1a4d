"""Evaluate one run: every metric of ``omnislam.metrics`` on a RunRecord, as a RunMetrics.

Which numbers mean what (every number is labelled with the kind of its ground truth; when that
is a reference solution computed by omnislam, ``GroundTruthInfo.reference`` names it, e.g.
"lm-optimum" for gtsam's victoria_park.txt, ``harness.reference``):

* ATE (``RunMetrics.ate``): SE(2)-aligned position errors (``ground_truth.alignment``), and
  with the first pose anchored instead (``origin_*``: drift shows fully).
* RPE (``rpe``): segments of ``segment_m`` metres of ground-truth travel (all start poses,
  evo's pair rule), SE(2) errors for planar runs; by default 10 m, shorter for a run that
  travels less than 40 m (``metrics.trajectory.auto_rpe_segment_m``: a quarter of its travel,
  rounded down to 1-2-5); ``frame_*``: consecutive frames (delta 1);
  ``by_distance``: the error-over-distance curve (KITTI-like segment lengths).
* Landmarks (``landmarks``): the estimate's map moved with the SE(2) trajectory alignment
  (or aligned on the landmarks themselves when there is no ground-truth trajectory), then
  matched by id when the sightings carried the true ids, else by optimal assignment within
  ``landmark_gate_m``.
* NEES (``nees``: poses and landmarks): in the estimate's frame with the ORIGIN alignment;
  None when the estimator gives no covariances.
* Timing (``timing``): per-step wall time, total, peak RSS of the run; none for results read
  from another system's files (``RunConfig.external``), which were not timed here.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from omnislam.datasets.sequence import GroundTruthKind
from omnislam.errors import ConfigError
from omnislam.harness.rundir import RunRecord
from omnislam.metrics.consistency import NeesResult, landmark_nees, pose_nees
from omnislam.metrics.landmarks import DEFAULT_LANDMARK_GATE_M, LandmarkAssociation, landmark_error
from omnislam.metrics.run_metrics import (
    AteMetrics,
    ConsistencyMetrics,
    GroundTruthInfo,
    LandmarkMetrics,
    RpeMetrics,
    RpeSegment,
    RunInfo,
    RunMetrics,
    TimingMetrics,
)
from omnislam.metrics.timing import timing_stats
from omnislam.metrics.trajectory import (
    Alignment,
    AteResult,
    DeltaUnit,
    accumulated_distances,
    associate,
    ate,
    auto_rpe_segment_m,
    rpe,
    segment_lengths,
    umeyama,
)

#: how reports name each kind of ground truth, next to every number
GROUND_TRUTH_LABELS: dict[GroundTruthKind, str] = {
    GroundTruthKind.EXACT: "exact ground truth (synthetic)",
    GroundTruthKind.MOTION_CAPTURE: "motion-capture ground truth (Vicon)",
    GroundTruthKind.GPS_PARTIAL: "GPS ground truth (partial, positions only)",
    GroundTruthKind.PSEUDO: "pseudo ground truth (corrected log; not independent)",
    GroundTruthKind.REFERENCE: "reference solution (not independent)",
    GroundTruthKind.NONE: "no ground truth",
}


@dataclass(frozen=True, slots=True)
class EvaluationOptions:
    """Settings of ``evaluate_run`` (stored in metrics.json with the numbers).

    Attributes:
        rpe_segment_m: segment length of ``RpeMetrics.trans_rmse_m`` [m]; None (the default):
            10 m, or a quarter of the ground truth's travel rounded down to 1-2-5 when the run
            travels less than 40 m (``metrics.trajectory.auto_rpe_segment_m``).
        landmark_gate_m: association gate for maps without true ids [m].
        curve_lengths: number of segment lengths in ``RpeMetrics.by_distance``.
    """

    rpe_segment_m: float | None = None
    landmark_gate_m: float = DEFAULT_LANDMARK_GATE_M
    curve_lengths: int = 8

    def __post_init__(self) -> None:
        """Raises ConfigError for a value of the wrong type or out of range (naming the key)."""
        if self.rpe_segment_m is not None and not _positive_number(self.rpe_segment_m):
            raise ConfigError(
                "rpe_segment_m must be a positive number (or null: chosen from the travel), "
                f"got {self.rpe_segment_m!r}"
            )
        if not _positive_number(self.landmark_gate_m):
            raise ConfigError(
                f"landmark_gate_m must be a positive number, got {self.landmark_gate_m!r}"
            )
        if (
            not isinstance(self.curve_lengths, int)
            or isinstance(self.curve_lengths, bool)
            or self.curve_lengths < 1
        ):
            raise ConfigError(
                f"curve_lengths must be a positive integer, got {self.curve_lengths!r}"
            )

    def segment_for(self, travel_m: float) -> float:
        """The RPE segment length used on a run that travels ``travel_m`` metres [m]."""
        if self.rpe_segment_m is not None:
            return float(self.rpe_segment_m)
        return auto_rpe_segment_m(travel_m)


def _positive_number(value: object) -> bool:
    """True for a finite real number > 0 (not a bool, not a string)."""
    return (
        isinstance(value, int | float)
        and not isinstance(value, bool)
        and math.isfinite(value)
        and value > 0
    )


def _finite(value: float | None) -> float | None:
    return float(value) if value is not None and math.isfinite(value) else None


def evaluate_run(record: RunRecord, options: EvaluationOptions | None = None) -> RunMetrics:
    """All metrics of one run against the ground truth stored with it.

    Args:
        record: the run (as written to and read back from its RUN_DIR).
        options: evaluation settings (defaults when None).

    Returns:
        The metrics; None where a metric cannot be computed (no ground truth, no covariances,
        no landmarks).
    """
    options = options if options is not None else EvaluationOptions()
    config, estimate, gt = record.config, record.estimate, record.ground_truth
    oriented = gt.kind is not GroundTruthKind.GPS_PARTIAL
    ate_metrics, rpe_metrics = AteMetrics(), RpeMetrics()
    se2: AteResult | None = None
    origin: AteResult | None = None
    pose_result: NeesResult | None = None
    if gt.trajectory is not None:
        se2 = ate(estimate.trajectory, gt.trajectory, Alignment.SE2, truth_has_orientation=oriented)
        origin = ate(
            estimate.trajectory, gt.trajectory, Alignment.ORIGIN, truth_has_orientation=oriented
        )
        ate_metrics = AteMetrics(
            rmse_m=_finite(se2.rmse_m),
            max_m=_finite(se2.max_m),
            mean_m=_finite(se2.mean_m),
            median_m=_finite(se2.median_m),
            origin_rmse_m=_finite(origin.rmse_m),
            origin_max_m=_finite(origin.max_m),
            matched=se2.matched,
            coverage=_finite(se2.coverage),
        )
        rpe_metrics = _rpe_metrics(record, options, oriented)
        if estimate.pose_covariances is not None:
            pose_result = pose_nees(
                estimate.trajectory,
                estimate.pose_covariances,
                gt.trajectory,
                truth_has_orientation=oriented,
            )
    landmark_result: NeesResult | None = None
    if len(gt.landmark_ids):
        landmarks, landmark_result = _landmark_metrics(record, options, se2, origin)
    else:
        landmarks = LandmarkMetrics(estimated=len(estimate.landmark_ids))
    timing = timing_stats(record.step_s if config.external is None else np.zeros(0))
    return RunMetrics(
        run=RunInfo(
            dataset=config.dataset,
            estimator=config.estimator,
            seed=config.seed,
            estimator_options=config.estimator_options,
            dataset_options=config.dataset_options,
        ),
        ate=ate_metrics,
        rpe=rpe_metrics,
        landmarks=landmarks,
        nees=ConsistencyMetrics(
            has_pose_covariances=estimate.pose_covariances is not None,
            pose_mean=None if pose_result is None else _finite(pose_result.mean),
            pose_median=None if pose_result is None else _finite(pose_result.median),
            pose_anees=None if pose_result is None else _finite(pose_result.anees),
            pose_dof=None if pose_result is None else pose_result.dof,
            pose_within_bounds=None if pose_result is None else _finite(pose_result.within_bounds),
            pose_count=None if pose_result is None else len(pose_result.values),
            has_landmark_covariances=estimate.landmark_covariances is not None,
            landmark_mean=None if landmark_result is None else _finite(landmark_result.mean),
            landmark_anees=None if landmark_result is None else _finite(landmark_result.anees),
            landmark_dof=None if landmark_result is None else landmark_result.dof,
            landmark_count=None if landmark_result is None else len(landmark_result.values),
        ),
        timing=TimingMetrics(
            frames=len(estimate.trajectory),
            step_median_ms=_finite(timing.median_ms),
            step_p95_ms=_finite(timing.p95_ms),
            step_mean_ms=_finite(timing.mean_ms),
            step_max_ms=_finite(timing.max_ms),
            total_s=config.total_s if config.external is None else None,
            peak_rss_mb=config.peak_rss_mb if config.external is None else None,
            warmup_s=timing.warmup_s if len(record.step_s) else None,
            warmup_steps=timing.warmup_steps if len(record.step_s) else None,
        ),
        ground_truth=GroundTruthInfo(
            alignment=Alignment.SE2 if se2 is not None else None,
            kind=gt.kind,
            label=GROUND_TRUTH_LABELS[gt.kind],
            note=gt.note,
            reference=config.ground_truth_reference,
        ),
    )


def _rpe_metrics(record: RunRecord, options: EvaluationOptions, oriented: bool) -> RpeMetrics:
    """RPE at the segment length, per frame, and over distance."""
    estimate, truth = record.estimate.trajectory, record.ground_truth.trajectory
    assert truth is not None
    _, i_gt = associate(estimate.stamps_s, truth.stamps_s)
    travel = float(accumulated_distances(truth.positions_w[i_gt])[-1]) if len(i_gt) else 0.0
    segment = options.segment_for(travel)
    main = rpe(estimate, truth, segment, DeltaUnit.METERS, truth_has_orientation=oriented)
    frame = rpe(estimate, truth, 1, DeltaUnit.FRAMES, truth_has_orientation=oriented)
    curve = []
    for length in segment_lengths(travel, options.curve_lengths):
        r = rpe(estimate, truth, length, DeltaUnit.METERS, truth_has_orientation=oriented)
        if r.count:
            curve.append(
                RpeSegment(
                    length_m=length,
                    trans_rmse_m=_finite(r.trans_rmse_m),
                    rot_rmse_deg=_finite(math.degrees(r.rot_rmse_rad)),
                    pairs=r.count,
                )
            )
    return RpeMetrics(
        segment_m=segment,
        trans_rmse_m=_finite(main.trans_rmse_m),
        rot_rmse_deg=_finite(math.degrees(main.rot_rmse_rad)),
        pairs=main.count,
        planar=main.planar,
        frame_trans_rmse_m=_finite(frame.trans_rmse_m),
        frame_rot_rmse_deg=_finite(math.degrees(frame.rot_rmse_rad)),
        travel_m=travel,
        by_distance=tuple(curve),
    )


def _landmark_metrics(
    record: RunRecord,
    options: EvaluationOptions,
    se2: AteResult | None,
    origin: AteResult | None,
) -> tuple[LandmarkMetrics, NeesResult | None]:
    """Landmark error and landmark NEES (None without landmark covariances or matches)."""
    estimate, gt = record.estimate, record.ground_truth
    by_id = record.config.landmark_ids_from_truth
    association = LandmarkAssociation.BY_ID if by_id else LandmarkAssociation.ASSIGNMENT
    labels = {
        "estimated": len(estimate.landmark_ids),
        "truth": len(gt.landmark_ids),
        "association": association,
        "gate_m": None if by_id else options.landmark_gate_m,
    }
    if not len(estimate.landmark_ids):
        nothing = LandmarkMetrics(
            matched=0, missed=len(gt.landmark_ids), duplicates=0, spurious=0, **labels
        )
        return nothing, None
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
        return LandmarkMetrics(**labels), None  # nothing relates the two frames
    result = landmark_error(
        estimate.landmark_ids,
        estimate.landmarks_w,
        gt.landmark_ids,
        gt.landmarks_w,
        gtTest,
        association,
        options.landmark_gate_m,
    )
    metrics = LandmarkMetrics(
        rmse_m=_finite(result.rmse_m),
        median_m=_finite(result.median_m),
        max_m=_finite(result.max_m),
        matched=result.matched,
        missed=result.missed,
        duplicates=result.duplicates,
        spurious=result.spurious,
        **labels,
    )
    nees = None
    if estimate.landmark_covariances is not None and result.matched and anchor is not None:
        nees = landmark_nees(
            estimate.landmarks_w[result.i_estimate],
            estimate.landmark_covariances[result.i_estimate],
            gt.landmarks_w[result.i_truth],
            anchor,
            result.planar,
        )
    return metrics, nees


def missing_reasons(metrics: RunMetrics) -> dict[str, str]:
    """Why a metric of ``metrics`` is None, for each that is: ``"ate"``, ``"rpe"``,
    ``"rpe_rot"``, ``"landmarks"``, ``"pose_nees"``, ``"landmark_nees"`` -> one short clause."""
    why: dict[str, str] = {}
    kind = metrics.ground_truth.kind
    if metrics.ate.rmse_m is None:
        why["ate"] = f"no ground-truth trajectory ({GROUND_TRUTH_LABELS[kind]})"
    rpe = metrics.rpe
    if rpe.trans_rmse_m is None:
        if metrics.ate.rmse_m is None:
            why["rpe"] = why["ate"]
        elif not rpe.pairs:
            travel = "?" if rpe.travel_m is None else f"{rpe.travel_m:.3g}"
            why["rpe"] = (
                f"no pose pair {rpe.segment_m:g} m of ground-truth travel apart (the run "
                f"travels {travel} m); choose a shorter --rpe-segment"
            )
    if rpe.rot_rmse_deg is None and rpe.trans_rmse_m is not None:
        why["rpe_rot"] = "the ground truth has no orientation (positions only)"
    marks = metrics.landmarks
    if marks.rmse_m is None:
        if marks.truth is None:
            why["landmarks"] = "the data has no ground-truth landmarks"
        elif marks.estimated == 0:
            why["landmarks"] = f"{metrics.run.estimator} keeps no landmark map"
        elif marks.matched == 0:
            gate = "" if marks.gate_m is None else f" within {marks.gate_m:g} m"
            why["landmarks"] = f"no estimated landmark matched a true one{gate}"
        else:
            why["landmarks"] = "nothing relates the estimated map to the true one"
    nees = metrics.nees
    if nees.pose_mean is None:
        why["pose_nees"] = (
            f"{metrics.run.estimator} gives no pose covariances"
            if not nees.has_pose_covariances
            else why.get("ate", "no usable pose covariance")
        )
    if nees.landmark_mean is None:
        why["landmark_nees"] = (
            f"{metrics.run.estimator} gives no landmark covariances"
            if not nees.has_landmark_covariances
            else why.get("landmarks", "no matched landmark with a usable covariance")
        )
    return why


@dataclass(frozen=True, slots=True)
class TrajectoryComparison:
    """An estimate against a reference trajectory (``omnislam evaluate --ref``).

    The numbers are evo's: ATE is ``evo_ape`` with the matching alignment flags (none, ``-a``,
    ``-as``, ``--align_origin``; SE(2) equals ``-a`` on planar runs), RPE is ``evo_rpe
    --all_pairs --pairs_from_reference`` with ``--delta SEGMENT --delta_unit m`` (and
    ``--delta 1 --delta_unit f``), of the estimate after the same alignment (only SIM3's scale
    changes an RPE).

    Attributes:
        ate: the ATE result (statistics and per-pose errors).
        rpe: RPE over segments of ``rpe.delta`` metres of reference travel.
        rpe_frame: RPE between consecutive associated poses.
        travel_m: the reference's travel over the associated poses [m].
        why: why a value is missing (``"rpe"`` -> reason), as ``missing_reasons``.
        aligned: the estimate after the alignment (a ``core.types.Trajectory`` in the
            reference's frame; what ``omnislam evaluate --plot`` draws).
    """

    ate: AteResult
    rpe: Any
    rpe_frame: Any
    travel_m: float
    why: dict[str, str]
    aligned: Any = None


def compare_trajectories(
    reference: Any,
    estimate: Any,
    alignment: Alignment = Alignment.SE2,
    rpe_segment_m: float | None = None,
) -> TrajectoryComparison:
    """ATE and RPE of ``estimate`` against ``reference`` (two ``core.types.Trajectory``).

    Args:
        reference: the ground truth.
        estimate: the estimate (poses associated to the reference's by stamp).
        alignment: how the estimate is aligned before ATE (and RPE).
        rpe_segment_m: RPE segment [m]; None: ``auto_rpe_segment_m`` of the reference's travel.

    Raises:
        DataError: fewer than 2 associated poses.
    """
    from omnislam.core.types import Trajectory

    result = ate(estimate, reference, alignment)
    _, i_gt = associate(estimate.stamps_s, reference.stamps_s)
    travel = float(accumulated_distances(reference.positions_w[i_gt])[-1])
    segment = rpe_segment_m if rpe_segment_m is not None else auto_rpe_segment_m(travel)
    T = result.gtTest
    rotation = T[:3, :3] / result.scale
    poses = estimate.poses_w.copy()
    poses[:, :3, :3] = rotation @ poses[:, :3, :3]
    poses[:, :3, 3] = poses[:, :3, 3] @ T[:3, :3].T + T[:3, 3]
    aligned = Trajectory(estimate.stamps_s, poses)
    main = rpe(aligned, reference, segment, DeltaUnit.METERS)
    frame = rpe(aligned, reference, 1, DeltaUnit.FRAMES)
    why = {}
    if not main.count:
        why["rpe"] = (
            f"no pose pair {segment:g} m of reference travel apart (the reference travels "
            f"{travel:.3g} m); choose a shorter --rpe-segment"
        )
    return TrajectoryComparison(result, main, frame, travel, why, aligned)
