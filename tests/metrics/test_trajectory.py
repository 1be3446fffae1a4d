"""ATE, alignment, stamp association and RPE (the same numbers as evo's)."""

import numpy as np
import pytest

from omnislam.core.se import se3_exp
from omnislam.core.types import Trajectory
from omnislam.metrics.trajectory import (
    ORIGIN_HEADING_BASELINE_M,
    Alignment,
    DeltaUnit,
    associate,
    ate,
    pairs_by_distance,
    rpe,
    umeyama,
)

TOL_M = 1e-9


def random_path(rng, n=200):
    steps = np.column_stack(
        [rng.uniform(0.1, 0.5, n), rng.normal(0, 0.02, n), rng.normal(0, 0.1, n)]
    )
    poses = np.zeros((n, 3))
    for k in range(1, n):
        c, s = np.cos(poses[k - 1, 2]), np.sin(poses[k - 1, 2])
        poses[k] = poses[k - 1] + [
            c * steps[k, 0] - s * steps[k, 1],
            s * steps[k, 0] + c * steps[k, 1],
            steps[k, 2],
        ]
    return np.arange(n, dtype=float), poses


def moved(poses, dx, dy, dtheta):
    c, s = np.cos(dtheta), np.sin(dtheta)
    out = poses.copy()
    out[:, 0] = c * poses[:, 0] - s * poses[:, 1] + dx
    out[:, 1] = s * poses[:, 0] + c * poses[:, 1] + dy
    out[:, 2] = poses[:, 2] + dtheta
    return out


def test_umeyama_recovers_a_similarity():
    rng = np.random.default_rng(1)
    src = rng.normal(size=(50, 3))
    T = se3_exp(np.array([1.0, -2.0, 0.5, 0.3, -0.2, 1.0]))
    dst = 1.7 * src @ T[:3, :3].T + T[:3, 3]
    R, t, s = umeyama(src, dst, with_scale=True)
    assert np.allclose(R, T[:3, :3]) and np.allclose(t, T[:3, 3]) and s == pytest.approx(1.7)


def test_umeyama_of_mirrored_points_is_the_best_proper_rotation():
    """Against a mirror image the unconstrained optimum is a reflection; Umeyama's sign
    correction must return the best *proper* rotation and its scale. In 2-D both have a closed
    form (Procrustes): theta* = atan2(sum xs x xt, sum xs . xt), s* = sum xt . R xs / sum |xs|^2.
    """
    rng = np.random.default_rng(8)
    src = rng.normal(size=(40, 2)) * [3.0, 1.0]
    dst = src * [-1.0, 1.0] + rng.normal(0, 0.1, size=src.shape) + [2.0, -1.0]  # mirrored in x
    xs, xt = src - src.mean(axis=0), dst - dst.mean(axis=0)
    theta = np.arctan2(np.sum(xs[:, 0] * xt[:, 1] - xs[:, 1] * xt[:, 0]), np.sum(xs * xt))
    R_star = np.array([[np.cos(theta), -np.sin(theta)], [np.sin(theta), np.cos(theta)]])
    s_star = np.sum(xt * (xs @ R_star.T)) / np.sum(xs**2)
    R, t, s = umeyama(src, dst, with_scale=True)
    assert np.linalg.det(R) == pytest.approx(1.0, abs=1e-12)
    np.testing.assert_allclose(R, R_star, atol=1e-12)
    assert s == pytest.approx(s_star, rel=1e-12)
    np.testing.assert_allclose(t, dst.mean(axis=0) - s_star * R_star @ src.mean(axis=0), atol=1e-12)


@pytest.mark.parametrize(
    "alignment", [Alignment.ORIGIN, Alignment.SE2, Alignment.SE3, Alignment.SIM3]
)
def test_a_rigidly_moved_copy_has_zero_ate(alignment):
    stamps, poses = random_path(np.random.default_rng(2))
    truth = Trajectory.from_se2(stamps, moved(poses, 3.0, -1.0, 0.7))
    result = ate(Trajectory.from_se2(stamps, poses), truth, alignment)
    assert result.rmse_m < 1e-6 and result.matched == len(stamps) and result.coverage == 1.0


def test_no_alignment_measures_the_offset():
    stamps, poses = random_path(np.random.default_rng(3))
    truth = Trajectory.from_se2(stamps, moved(poses, 3.0, 4.0, 0.0))
    assert ate(Trajectory.from_se2(stamps, poses), truth, Alignment.NONE).rmse_m == pytest.approx(
        5.0
    )


def test_origin_keeps_drift_that_se2_hides():
    stamps, poses = random_path(np.random.default_rng(4))
    drifted = poses.copy()
    drifted[:, :2] += np.linspace(0, 1, len(poses))[:, None] * [2.0, 0.0]
    est, truth = Trajectory.from_se2(stamps, drifted), Trajectory.from_se2(stamps, poses)
    origin = ate(est, truth, Alignment.ORIGIN)
    assert origin.max_m == pytest.approx(2.0)
    assert ate(est, truth, Alignment.SE2).rmse_m < origin.rmse_m


def test_origin_alignment_without_ground_truth_heading_uses_the_start_of_the_run():
    stamps, poses = random_path(np.random.default_rng(5))
    truth_xy = moved(poses, 1.0, 2.0, 0.4)
    truth_xy[:, 2] = 0.0  # GPS: no heading
    result = ate(
        Trajectory.from_se2(stamps, poses),
        Trajectory.from_se2(stamps, truth_xy),
        Alignment.ORIGIN,
        truth_has_orientation=False,
    )
    assert result.rmse_m < 1e-6


def test_origin_alignment_without_heading_fits_only_the_first_baseline_of_travel():
    """Position-only truth: ORIGIN fits on the pairs within ORIGIN_HEADING_BASELINE_M of travel,
    so drift after the baseline shows in full and the start stays exact."""
    stamps, poses = random_path(np.random.default_rng(9))
    gt_xy = poses[:, :2]
    travel = np.r_[0.0, np.cumsum(np.linalg.norm(np.diff(gt_xy, axis=0), axis=1))]
    late = travel > ORIGIN_HEADING_BASELINE_M + 5.0
    assert late.sum() > len(stamps) // 2  # the run is much longer than the baseline
    drifted = poses.copy()
    drifted[late, 1] += 3.0  # 3 m lateral offset, well after the baseline
    truth_xy = moved(poses, 1.0, 2.0, 0.4)
    truth_xy[:, 2] = 0.0  # GPS: no heading
    result = ate(
        Trajectory.from_se2(stamps, moved(drifted, -4.0, 0.5, -1.1)),
        Trajectory.from_se2(stamps, truth_xy),
        Alignment.ORIGIN,
        truth_has_orientation=False,
    )
    np.testing.assert_allclose(result.errors_m[~late], 0.0, atol=1e-9)
    np.testing.assert_allclose(result.errors_m[late], 3.0, rtol=1e-9)


def test_association_keeps_the_closest_estimate_for_each_truth_stamp():
    i_est, i_gt = associate(np.array([0.995, 1.002, 1.009]), np.array([1.0]), 0.01)
    assert list(i_est) == [1] and list(i_gt) == [0]


def test_association_by_nearest_stamp_within_tolerance():
    i_est, i_gt = associate(
        np.array([0.0, 1.0, 2.0, 3.0]), np.array([0.004, 2.2, 2.999, 3.001]), 0.01
    )
    assert list(i_est) == [0, 3] and list(i_gt) == [0, 2]


def test_partial_ground_truth_reports_coverage():
    stamps, poses = random_path(np.random.default_rng(6))
    keep = np.r_[0:50, 120:200]
    truth = Trajectory.from_se2(stamps[keep], poses[keep])
    result = ate(Trajectory.from_se2(stamps, poses), truth, Alignment.SE2)
    assert result.matched == len(keep) and result.coverage == pytest.approx(len(keep) / 200)


@pytest.mark.parametrize(("alignment", "scale"), [(Alignment.SE3, False), (Alignment.SIM3, True)])
def test_matches_evo_ape(alignment, scale):
    evo_sync = pytest.importorskip("evo.core.sync")
    from evo.core import metrics
    from evo.core.trajectory import PoseTrajectory3D

    rng = np.random.default_rng(7)
    n = 100
    poses = se3_exp(np.cumsum(rng.normal(0, 0.1, size=(n, 6)), axis=0))
    noisy = poses @ se3_exp(rng.normal(0, 0.05, size=(n, 6)))
    stamps = np.arange(n, dtype=float)
    ours = ate(Trajectory(stamps, noisy), Trajectory(stamps, poses), alignment)
    ref = PoseTrajectory3D(poses_se3=list(poses), timestamps=stamps)
    est = PoseTrajectory3D(poses_se3=list(noisy), timestamps=stamps)
    ref, est = evo_sync.associate_trajectories(ref, est)
    est.align(ref, correct_scale=scale)
    ape = metrics.APE(metrics.PoseRelation.translation_part)
    ape.process_data((ref, est))
    assert ours.rmse_m == pytest.approx(ape.get_statistic(metrics.StatisticsType.rmse), rel=1e-9)
    assert ours.max_m == pytest.approx(ape.get_statistic(metrics.StatisticsType.max), rel=1e-9)


# ---------------------------------------------------------------------------------------------
# evo as the oracle: APE for every alignment both implement, RPE where the definitions coincide
# ---------------------------------------------------------------------------------------------

EVO_TOL_M = 1e-9  # our ATE/RPE vs evo's, absolute [m] (and [rad] for rotations)


def _evo():
    pytest.importorskip("evo")
    from evo.core import metrics as evo_metrics
    from evo.core.trajectory import PoseTrajectory3D

    return evo_metrics, PoseTrajectory3D


def _random_se3_pair(seed, n=120):
    rng = np.random.default_rng(seed)
    poses = se3_exp(np.cumsum(rng.normal(0, 0.1, size=(n, 6)), axis=0))
    noisy = poses @ se3_exp(rng.normal(0, 0.05, size=(n, 6)))
    return np.arange(n, dtype=float), poses, noisy


def _random_planar_pair(seed, n=150):
    rng = np.random.default_rng(seed)
    stamps, truth = random_path(rng, n)
    est = moved(truth, 2.0, -3.0, 0.6)
    est[:, :2] += rng.normal(0, 0.05, size=(n, 2))
    est[:, 2] += rng.normal(0, 0.02, n)
    return (
        stamps,
        Trajectory.from_se2(stamps, truth).poses_w,
        Trajectory.from_se2(stamps, est).poses_w,
    )


@pytest.mark.parametrize("seed", [11, 12])
@pytest.mark.parametrize(
    ("ours", "evo_mode", "planar"),
    [
        (Alignment.NONE, "none", False),
        (Alignment.ORIGIN, "origin", False),
        (Alignment.SE3, "se3", False),
        (Alignment.SIM3, "sim3", False),
        # planar runs: our SE(2) Umeyama equals evo's SE(3) Umeyama (same optimum in the plane)
        (Alignment.SE2, "se3", True),
    ],
)
def test_ate_equals_evo_ape(seed, ours, evo_mode, planar):
    evo_metrics, PoseTrajectory3D = _evo()
    stamps, truth, est = (_random_planar_pair if planar else _random_se3_pair)(seed)
    result = ate(Trajectory(stamps, est), Trajectory(stamps, truth), ours)
    ref = PoseTrajectory3D(poses_se3=list(truth), timestamps=stamps)
    evo_est = PoseTrajectory3D(poses_se3=list(est), timestamps=stamps)
    if evo_mode == "origin":
        evo_est.align_origin(ref)
    elif evo_mode in ("se3", "sim3"):
        evo_est.align(ref, correct_scale=evo_mode == "sim3")
    ape = evo_metrics.APE(evo_metrics.PoseRelation.translation_part)
    ape.process_data((ref, evo_est))
    stats = evo_metrics.StatisticsType
    assert abs(result.rmse_m - ape.get_statistic(stats.rmse)) < EVO_TOL_M
    assert abs(result.max_m - ape.get_statistic(stats.max)) < EVO_TOL_M
    assert abs(result.mean_m - ape.get_statistic(stats.mean)) < EVO_TOL_M
    assert abs(result.median_m - ape.get_statistic(stats.median)) < EVO_TOL_M


def _evo_rpe(truth, est, stamps, relation, delta, unit, all_pairs):
    evo_metrics, PoseTrajectory3D = _evo()
    ref = PoseTrajectory3D(poses_se3=list(truth), timestamps=stamps)
    evo_est = PoseTrajectory3D(poses_se3=list(est), timestamps=stamps)
    metric = evo_metrics.RPE(
        relation,
        delta,
        evo_metrics.Unit.frames if unit is DeltaUnit.FRAMES else evo_metrics.Unit.meters,
        rel_delta_tol=0.1,
        all_pairs=all_pairs,
        pairs_from_reference=True,
    )
    metric.process_data((ref, evo_est))
    return metric


@pytest.mark.parametrize("planar", [False, True])
@pytest.mark.parametrize(
    ("delta", "unit", "all_pairs"),
    [
        (1, DeltaUnit.FRAMES, False),
        (5, DeltaUnit.FRAMES, False),
        (5, DeltaUnit.FRAMES, True),
        (2.0, DeltaUnit.METERS, True),
        (7.5, DeltaUnit.METERS, True),
    ],
)
def test_rpe_equals_evo_rpe(planar, delta, unit, all_pairs):
    evo_metrics, _ = _evo()
    stamps, truth, est = (_random_planar_pair if planar else _random_se3_pair)(21)
    ours = rpe(Trajectory(stamps, est), Trajectory(stamps, truth), delta, unit, all_pairs=all_pairs)
    assert ours.planar is planar and ours.count > 5
    trans = _evo_rpe(
        truth, est, stamps, evo_metrics.PoseRelation.translation_part, delta, unit, all_pairs
    )
    rot = _evo_rpe(
        truth, est, stamps, evo_metrics.PoseRelation.rotation_angle_rad, delta, unit, all_pairs
    )
    assert [j for _, j in ours.pairs] == list(trans.delta_ids)
    assert np.max(np.abs(ours.trans_errors_m - trans.error)) < EVO_TOL_M
    assert np.max(np.abs(ours.rot_errors_rad - rot.error)) < EVO_TOL_M
    rmse = evo_metrics.StatisticsType.rmse
    assert abs(ours.trans_rmse_m - trans.get_statistic(rmse)) < EVO_TOL_M


def test_pairs_by_distance_handles_a_robot_standing_still():
    evo_filters = pytest.importorskip("evo.core.filters")
    positions = np.array([[0, 0], [1, 0], [1, 0], [1, 0], [2, 0], [3, 0], [3, 0], [5, 0]], float)
    ours = pairs_by_distance(positions, 1.0, 0.1)
    poses = [np.eye(4) for _ in positions]
    for pose, p in zip(poses, positions, strict=True):
        pose[:2, 3] = p
    theirs = evo_filters.filter_pairs_by_path(poses, 1.0, 0.1, all_pairs=True)
    assert [tuple(p) for p in ours] == theirs


def test_rpe_of_a_rigidly_moved_copy_is_zero_and_drift_shows():
    stamps, poses = random_path(np.random.default_rng(30))
    truth = Trajectory.from_se2(stamps, poses)
    assert rpe(Trajectory.from_se2(stamps, moved(poses, 5, 1, 2.0)), truth, 5.0).trans_rmse_m < 1e-9
    scaled = poses.copy()
    scaled[:, :2] *= 1.1  # 10 % odometry scale error: 10 % of every segment
    result = rpe(Trajectory.from_se2(stamps, scaled), truth, 10.0)
    assert np.median(result.trans_errors_m) == pytest.approx(1.0, rel=0.15)
    assert np.max(result.rot_errors_rad) < 1e-9


def test_rpe_against_position_only_truth_has_no_rotation_error():
    stamps, poses = random_path(np.random.default_rng(31))
    gps = moved(poses, 1, 2, 0.5)
    gps[:, 2] = 0.0
    result = rpe(
        Trajectory.from_se2(stamps, poses),
        Trajectory.from_se2(stamps, gps),
        5.0,
        truth_has_orientation=False,
    )
    assert result.rot_errors_rad is None and result.trans_rmse_m < 1e-9
