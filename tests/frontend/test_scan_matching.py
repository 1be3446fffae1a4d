"""Laser odometry by ICP (frontend.scan_matching): a known motion is recovered, degenerate
matches fall back to the wheel odometry, and the log hands the result to the estimators."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

pytest.importorskip("open3d")

from omnislam.core.se import se2_between, se2_compose, se2_integrate, wrap_angle
from omnislam.core.types import OdometrySource
from omnislam.frontend.config import LaserOdometryConfig
from omnislam.frontend.scan_matching import (
    Reason,
    laser_odometry,
    match_scans,
    scan_points,
)

ANGLES = np.deg2rad(np.arange(-90.0, 90.0, 1.0))
MAX_RANGE = 30.0
#: a 10 x 6 m room with a 1 m box in it
ROOM = [((0, 0), (10, 0)), ((10, 0), (10, 6)), ((10, 6), (0, 6)), ((0, 6), (0, 0)),
        ((6, 2), (7, 2)), ((7, 2), (7, 3)), ((7, 3), (6, 3)), ((6, 3), (6, 2))]
#: a corridor: two long parallel walls, nothing across
CORRIDOR = [((-50, -1), (50, -1)), ((-50, 1), (50, 1))]


def cast(pose, walls, noise=0.0, rng=None):
    """Ranges of the beams ANGLES from ``pose`` to the nearest wall segment (MAX_RANGE: none)."""
    x, y, th = pose
    ranges = np.full(ANGLES.shape, MAX_RANGE)
    d = np.column_stack([np.cos(th + ANGLES), np.sin(th + ANGLES)])
    for (ax, ay), (bx, by) in walls:
        e = np.array([bx - ax, by - ay])
        w = np.array([ax - x, ay - y])
        den = d[:, 0] * (-e[1]) - d[:, 1] * (-e[0])
        with np.errstate(divide="ignore", invalid="ignore"):
            t = (w[0] * (-e[1]) - w[1] * (-e[0])) / den
            s = (d[:, 0] * w[1] - d[:, 1] * w[0]) / den
        hit = (np.abs(den) > 1e-12) & (t > 0) & (s >= 0) & (s <= 1)
        ranges = np.where(hit & (t < ranges), t, ranges)
    if noise:
        ranges = ranges + rng.normal(0.0, noise, ranges.shape)
    return ranges


def points(ranges, config=None):
    return scan_points(ANGLES, ranges, MAX_RANGE, config or LaserOdometryConfig())


def test_a_known_rigid_motion_is_recovered_from_a_wrong_guess():
    rng = np.random.default_rng(3)
    a = np.array([2.0, 1.5, 0.3])
    motion = np.array([0.6, -0.1, 0.25])  # the new pose in the previous one's frame
    b = se2_compose(a, motion)
    target = points(cast(a, ROOM, 0.01, rng))
    source = points(cast(b, ROOM, 0.01, rng))
    guess = motion + np.array([0.12, -0.08, np.deg2rad(4.0)])  # the wheels' error
    match = match_scans(source, target, guess, LaserOdometryConfig())
    assert match.reason is Reason.ACCEPTED
    assert np.hypot(*(match.delta[:2] - motion[:2])) < 0.02
    assert abs(wrap_angle(match.delta[2] - motion[2])) < np.deg2rad(0.3)
    assert match.fitness > 0.9 and match.rmse_m < 0.03
    # the stated covariance covers the error, and is positive definite
    assert np.all(np.linalg.eigvalsh(match.covariance) > 0)
    err = match.delta - motion
    assert err @ np.linalg.solve(match.covariance, err) < 16.27  # chi2(3) 99.9 %


def test_a_corridor_is_degenerate_and_keeps_the_wheel_odometry_along_it():
    rng = np.random.default_rng(4)
    a = np.array([0.0, 0.0, 0.0])
    motion = np.array([0.8, 0.0, 0.02])
    target = points(cast(a, CORRIDOR, 0.01, rng))
    source = points(cast(se2_compose(a, motion), CORRIDOR, 0.01, rng))
    guess = np.array([0.5, 0.03, 0.0])
    config = LaserOdometryConfig()
    match = match_scans(source, target, guess, config)
    assert match.reason is Reason.DEGENERATE and match.accepted
    assert match.min_translation_information < 0.01
    # along the corridor: the wheels' 0.5 m (the scans cannot tell), with the odometry's std
    assert match.delta[0] == pytest.approx(guess[0], abs=1e-3)
    sigma_along = config.degenerate_sigma_m + config.degenerate_sigma_fraction * 0.5
    assert np.sqrt(match.covariance[0, 0]) == pytest.approx(sigma_along, rel=0.05)
    # across it and in rotation: the scans' (true 0 m and 0.02 rad), tightly
    assert abs(match.delta[1]) < 0.01 and abs(match.delta[2] - 0.02) < np.deg2rad(0.2)
    assert np.sqrt(match.covariance[1, 1]) < 0.05


def test_a_sharp_turn_with_under_half_of_the_scan_overlapping_is_accepted():
    # carmen-aces frame 169 turns 78 deg in one step: about half of the 180-deg scan still sees
    # what the previous one saw, the wheels are 4.4 deg off; the right match must not fall back
    rng = np.random.default_rng(9)
    a = np.array([3.0, 3.0, 0.0])
    motion = np.array([0.1, -0.3, -1.75])
    target = points(cast(a, ROOM, 0.01, rng))
    source = points(cast(se2_compose(a, motion), ROOM, 0.01, rng))
    guess = motion + np.array([0.1, 0.1, np.deg2rad(-4.4)])
    match = match_scans(source, target, guess, LaserOdometryConfig())
    assert match.fitness < 0.5
    assert match.reason is Reason.ACCEPTED
    assert np.hypot(*(match.delta[:2] - motion[:2])) < 0.03
    assert abs(wrap_angle(match.delta[2] - motion[2])) < np.deg2rad(0.3)


def test_a_poor_fit_falls_back_to_the_wheel_odometry():
    rng = np.random.default_rng(8)
    target = points(cast((0.0, 0.0, 0.0), CORRIDOR, 0.01, rng))
    source = points(cast((2.0, 1.5, 0.3), ROOM, 0.01, rng))  # another place altogether
    guess = np.array([0.5, 0.0, 0.1])
    match = match_scans(source, target, guess, LaserOdometryConfig())
    assert match.reason is Reason.POOR_FIT and not match.accepted
    assert match.covariance is None
    np.testing.assert_array_equal(match.delta, guess)


def test_too_few_points_and_a_match_far_from_the_odometry_are_rejected():
    rng = np.random.default_rng(5)
    config = LaserOdometryConfig()
    a = np.array([2.0, 1.5, 0.3])
    motion = np.array([0.6, -0.1, 0.25])
    target = points(cast(a, ROOM, 0.01, rng))
    source = points(cast(se2_compose(a, motion), ROOM, 0.01, rng))
    assert match_scans(source[:5], target, motion, config).reason is Reason.TOO_FEW_POINTS
    tight = replace(config, gate_translation_m=0.01, gate_translation_fraction=0.0)
    off = motion + np.array([0.2, 0.0, 0.0])
    match = match_scans(source, target, off, tight)
    assert match.reason is Reason.DISAGREES_WITH_ODOMETRY
    np.testing.assert_array_equal(match.delta, off)


def test_laser_odometry_of_a_path_beats_the_wheels_and_falls_back_in_a_corridor():
    rng = np.random.default_rng(6)
    truth = np.array([[1.0 + 0.5 * k, 1.0 + 0.3 * k, 0.1 * k] for k in range(8)])
    ranges = np.array([cast(p, ROOM, 0.01, rng) for p in truth])
    true_deltas = np.zeros((8, 3))
    true_deltas[1:] = se2_between(truth[:-1], truth[1:])
    wheels = true_deltas + np.r_[[[0, 0, 0]], rng.normal(0, [0.05, 0.05, 0.03], (7, 3))]
    lo = laser_odometry(ANGLES, ranges, MAX_RANGE, wheels, LaserOdometryConfig())
    assert lo.accepted[1:].all() and not lo.accepted[0]
    err_laser = se2_integrate(lo.deltas, truth[0])[-1] - truth[-1]
    err_wheels = se2_integrate(wheels, truth[0])[-1] - truth[-1]
    assert np.hypot(*err_laser[:2]) < 0.05 < np.hypot(*err_wheels[:2])
    # a corridor: every match degenerate: the wheels' translation along it, the scans' across
    corridor = np.array([cast((0.7 * k, 0.0, 0.0), CORRIDOR, 0.01, rng) for k in range(4)])
    wheels = np.r_[[[0.0, 0.0, 0.0]], np.tile([0.65, 0.02, 0.01], (3, 1))]
    lo = laser_odometry(ANGLES, corridor, MAX_RANGE, wheels, LaserOdometryConfig())
    assert lo.reasons[1:] == ("degenerate",) * 3
    np.testing.assert_allclose(lo.deltas[1:, 0], 0.65, atol=2e-3)
    assert np.all(np.abs(lo.deltas[1:, 1:]) < 0.01)  # the wheels' 2 cm and 0.01 rad corrected
    # rejected matches keep the wheel odometry as it is, and no covariance is invented
    empty = np.full_like(corridor, MAX_RANGE)
    lo = laser_odometry(ANGLES, empty, MAX_RANGE, wheels, LaserOdometryConfig())
    assert not lo.accepted.any() and lo.reasons[1:] == ("too-few-points",) * 3
    np.testing.assert_array_equal(lo.deltas, wheels)
    assert np.isnan(lo.covariances).all()


def test_the_log_carries_the_laser_odometry_to_slam_estimators_not_to_dead_reckoning(tmp_path):
    from omnislam.core.types import Trajectory
    from omnislam.datasets.sequence import GroundTruth, GroundTruthKind, LaserScans, Sequence
    from omnislam.frontend.config import FrontendConfig
    from omnislam.frontend.observation_log import load_observation_log, save_observation_log
    from omnislam.frontend.pipeline import run_frontend

    rng = np.random.default_rng(7)
    truth = np.array([[1.0 + 0.5 * k, 1.0 + 0.3 * k, 0.1 * k] for k in range(6)])
    deltas = np.zeros((6, 3))
    deltas[1:] = se2_between(truth[:-1], truth[1:])
    wheels = deltas + np.r_[[[0, 0, 0]], rng.normal(0, [0.05, 0.05, 0.03], (5, 3))]
    stamps = np.arange(6.0)
    sequence = Sequence(
        name="room",
        source="test",
        stamps_s=stamps,
        odometry_r=wheels,
        ground_truth=GroundTruth(GroundTruthKind.EXACT, Trajectory.from_se2(stamps, truth)),
        laser=LaserScans(ANGLES, np.array([cast(p, ROOM, 0.01, rng) for p in truth]), MAX_RANGE),
    )
    log = run_frontend(sequence, FrontendConfig())
    assert log.odometry_source is OdometrySource.LASER and log.stats["laser_odometry_accepted"] == 5
    path = tmp_path / "room.npz"
    save_observation_log(log, path)
    loaded = load_observation_log(path)
    assert loaded.odometry_source is OdometrySource.LASER
    for a, b in zip(log.frames, loaded.frames, strict=True):
        np.testing.assert_array_equal(a.odometry.delta, b.odometry.delta)
        assert (a.odometry.covariance is None) == (b.odometry.covariance is None)
    fed = list(sequence.frame_inputs(loaded.frames, odometry=True))
    raw = list(sequence.frame_inputs(loaded.frames))
    assert not np.allclose(fed[3].odometry.delta, wheels[3])
    np.testing.assert_array_equal(raw[3].odometry.delta, wheels[3])
    assert fed[3].odometry.covariance is not None and raw[3].odometry.covariance is None
    no_laser = run_frontend(
        sequence, replace(FrontendConfig(), laser_odometry=LaserOdometryConfig(enabled=False))
    )
    assert no_laser.odometry_source is OdometrySource.WHEEL
    np.testing.assert_array_equal(no_laser.frames[3].odometry.delta, wheels[3])


def test_the_submap_thinning_keeps_one_mean_point_per_cell():
    from omnislam.frontend.scan_matching import _voxel

    # two clusters far smaller than a cell and a metre apart (wherever the grid is anchored)
    points = np.array([[0.0, 0.0], [0.02, 0.02], [1.0, 1.0], [1.02, 1.01], [1.01, 1.02]])
    thinned = _voxel(points, 0.1)
    order = np.argsort(thinned[:, 0])
    expected = [points[:2].mean(axis=0), points[2:].mean(axis=0)]
    np.testing.assert_allclose(thinned[order], expected, atol=1e-9)


def test_registration_runs_on_one_open3d_thread_and_repeats_bit_for_bit(monkeypatch):
    # open3d's multi-threaded sums merge in a run-dependent order (scan_matching docstring,
    # "Determinism"); two threads here rarely differ on a synthetic room, so the test checks
    # both the cause (one thread inside every ICP call, the caller's limit restored) and the
    # effect (identical increments and covariances over repeated registrations)
    import open3d as o3d

    if not hasattr(o3d.utility, "set_max_threads"):
        pytest.skip("this open3d has no thread limit (OpenMP builds: OMP_NUM_THREADS=1)")
    registration = o3d.pipelines.registration
    icp = registration.registration_icp
    threads_seen = []

    def spy(*args, **kwargs):
        threads_seen.append(o3d.utility.get_max_threads())
        return icp(*args, **kwargs)

    monkeypatch.setattr(registration, "registration_icp", spy)
    rng = np.random.default_rng(5)
    a = np.array([2.0, 1.5, 0.3])
    motion = np.array([0.4, -0.05, 0.15])
    target = points(cast(a, ROOM, 0.02, rng))
    source = points(cast(se2_compose(a, motion), ROOM, 0.02, rng))
    guess = motion + np.array([0.05, -0.03, np.deg2rad(2.0)])
    o3d.utility.set_max_threads(0)  # the automatic default: every core
    automatic = o3d.utility.get_max_threads()
    try:
        matches = [match_scans(source, target, guess, LaserOdometryConfig()) for _ in range(10)]
        assert o3d.utility.get_max_threads() == automatic
    finally:
        o3d.utility.set_max_threads(0)
    assert threads_seen and set(threads_seen) == {1}
    assert matches[0].reason is Reason.ACCEPTED
    for match in matches[1:]:
        np.testing.assert_array_equal(match.delta, matches[0].delta)
        np.testing.assert_array_equal(match.covariance, matches[0].covariance)
