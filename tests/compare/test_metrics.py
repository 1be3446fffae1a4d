"""ATE, alignment and stamp association."""

import numpy as np
import pytest

from omnislam.compare.metrics import Alignment, associate, ate, umeyama
from omnislam.core.se import se3_exp
from omnislam.core.types import Trajectory

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
