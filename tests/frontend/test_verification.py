"""RANSAC on bearing vectors: exact solvers, decomposition, robustness, the odometry guard."""

from __future__ import annotations

import numpy as np

from omnislam.frontend.config import VerificationConfig
from omnislam.frontend.verification import (
    ModelKind,
    RelativePose,
    beyond_the_floor,
    decompose_essential,
    decompose_planar_essential,
    epipolar_errors,
    essential_from_bearings,
    planar_essential_from_bearings,
    rotation_angle,
    verify_matches,
)

#: solvers on noise-free data agree with the truth to this [rad]
EXACT_RAD = 1e-8


def _scene(rng, n=200, delta=(0.3, 0.1, 0.2), viewpoint=(0.0, 0.0, 0.85)):
    """Points all around a central camera (full sphere) and their bearings in two views."""
    pose = RelativePose.from_planar_motion(np.array(delta), np.array(viewpoint))
    directions = rng.normal(size=(n, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    points_1 = directions * rng.uniform(1.0, 6.0, size=(n, 1))
    points_2 = (points_1 - pose.t) @ pose.R  # R^T (p1 - t)
    f1 = points_1 / np.linalg.norm(points_1, axis=1, keepdims=True)
    f2 = points_2 / np.linalg.norm(points_2, axis=1, keepdims=True)
    return pose, f1, f2


def test_epipolar_error_is_zero_for_the_true_pose_and_an_angle_otherwise():
    rng = np.random.default_rng(1)
    pose, f1, f2 = _scene(rng)
    assert np.max(epipolar_errors(pose.essential(), f1, f2)) < EXACT_RAD
    # rotating f1 about the epipolar plane normal by a known angle gives that angle back
    n = pose.essential() @ f2[0]
    n /= np.linalg.norm(n)
    angle = 0.01
    axis = np.cross(n, f1[0])
    axis /= np.linalg.norm(axis)
    tilted = np.cos(angle) * f1[0] + np.sin(angle) * np.cross(axis, f1[0])
    err = epipolar_errors(pose.essential(), tilted[None], f2[:1])[0]
    # f1 now leaves its epipolar plane by exactly `angle`; the residual is the larger of the
    # two sides' angles, so it is at least that and of the same size
    assert angle - 1e-9 <= err < 1.5 * angle


def test_eight_point_on_the_whole_sphere_recovers_the_pose():
    rng = np.random.default_rng(2)
    pose, f1, f2 = _scene(rng, n=8)
    E = essential_from_bearings(f1, f2)
    assert np.max(epipolar_errors(E, f1, f2)) < 1e-7
    est = decompose_essential(E, f1, f2)
    assert rotation_angle(est.R @ pose.R.T) < 1e-7
    assert np.allclose(est.t, pose.t / np.linalg.norm(pose.t), atol=1e-7)


def test_three_point_planar_solver_recovers_a_planar_motion():
    rng = np.random.default_rng(7)
    pose, f1, f2 = _scene(rng, n=3, delta=(-0.4, 0.25, -0.7))
    E = planar_essential_from_bearings(f1, f2)
    # exact on the three, and the form of [t]x Rz: singular values (s, s, 0)
    assert np.max(epipolar_errors(E, f1, f2)) < EXACT_RAD
    singular = np.linalg.svd(E, compute_uv=False)
    assert abs(singular[0] - singular[1]) < 1e-9 * singular[0] and singular[2] < 1e-12
    _, g1, g2 = _scene(np.random.default_rng(8), n=50, delta=(-0.4, 0.25, -0.7))
    est = decompose_planar_essential(E, g1, g2)
    assert rotation_angle(est.R @ pose.R.T) < EXACT_RAD
    assert np.allclose(est.t, pose.t / np.linalg.norm(pose.t), atol=1e-8)
    # least squares over many pairs agrees with the 8-point solution up to sign and scale
    _, h1, h2 = _scene(np.random.default_rng(9), n=40)
    planar = planar_essential_from_bearings(h1, h2)
    general = essential_from_bearings(h1, h2)
    planar, general = planar / np.linalg.norm(planar), general / np.linalg.norm(general)
    assert min(np.abs(planar - general).max(), np.abs(planar + general).max()) < 1e-8


def test_the_planar_model_refuses_a_motion_off_the_plane():
    """A tilted second view (not a wheeled robot's motion) is verified only by the general
    model: the planar one cannot explain the matches."""
    rng = np.random.default_rng(10)
    _, f1, f2 = _scene(rng, n=200)
    tilt = 0.1  # rad about the x axis
    Rx = np.array([[1.0, 0.0, 0.0], [0.0, np.cos(tilt), -np.sin(tilt)],
                   [0.0, np.sin(tilt), np.cos(tilt)]])
    f2 = f2 @ Rx  # the second camera is rotated by Rx^T
    planar = verify_matches(f1, f2, None, VerificationConfig(), np.random.default_rng(0))
    general = verify_matches(f1, f2, None, VerificationConfig(planar_motion=False),
                             np.random.default_rng(0))
    assert general.n_inliers == 200
    assert planar.n_inliers < 100


def test_ransac_separates_outliers_and_respects_the_threshold():
    rng = np.random.default_rng(3)
    pose, f1, f2 = _scene(rng, n=300)
    noise = 0.001
    f2 = f2 + rng.normal(scale=noise, size=f2.shape)
    f2 /= np.linalg.norm(f2, axis=1, keepdims=True)
    outliers = rng.random(300) < 0.4
    shuffled = rng.permutation(np.flatnonzero(outliers))
    f2[outliers] = f2[shuffled]
    config = VerificationConfig(threshold_rad=0.005)
    result = verify_matches(f1, f2, None, config, np.random.default_rng(0))
    assert result.kind is ModelKind.ESSENTIAL
    true_inliers = epipolar_errors(pose.essential(), f1, f2) < config.threshold_rad
    agreement = np.mean(result.inliers == true_inliers)
    assert agreement > 0.98
    assert rotation_angle(result.pose.R @ pose.R.T) < 0.01


def test_the_odometry_prior_seeds_and_guards():
    rng = np.random.default_rng(4)
    _, f1, f2 = _scene(rng, n=150)
    prior = RelativePose.from_planar_motion(np.array([0.3, 0.1, 0.2]), np.array([0, 0, 0.85]))
    seeded = verify_matches(f1, f2, prior, VerificationConfig(), np.random.default_rng(0))
    assert seeded.n_inliers == 150
    # a prior whose rotation is 60 deg off refuses the (correct) image geometry
    wrong = RelativePose.from_planar_motion(np.array([0.3, 0.1, 0.2 + 1.05]), np.zeros(3))
    guarded = verify_matches(f1, f2, wrong, VerificationConfig(), np.random.default_rng(0))
    assert guarded.n_inliers == 0


def test_small_baseline_switches_to_the_rotation_model():
    rng = np.random.default_rng(5)
    pose, f1, f2 = _scene(rng, n=100, delta=(0.0, 0.0, 0.3), viewpoint=(0.0, 0.0, 0.0))
    prior = RelativePose.from_planar_motion(np.array([0.0, 0.0, 0.3]), np.zeros(3))
    result = verify_matches(f1, f2, prior, VerificationConfig(), np.random.default_rng(0))
    assert result.kind is ModelKind.ROTATION
    assert result.n_inliers == 100
    assert rotation_angle(result.pose.R @ pose.R.T) < 1e-6


def test_too_few_matches_are_rejected_not_guessed():
    rng = np.random.default_rng(6)
    _, f1, f2 = _scene(rng, n=5)
    result = verify_matches(f1, f2, None, VerificationConfig(), rng)
    assert result.kind is ModelKind.NONE and result.n_inliers == 0


def test_the_epipolar_error_is_the_larger_angle_to_either_epipolar_plane():
    """asin(|f1^T E f2| / min(|E f2|, |E^T f1|)): of f1 to the plane of normal E f2 and of f2
    to the plane of normal E^T f1 (one numerator), the larger angle."""
    rng = np.random.default_rng(8)
    pose, f1, f2 = _scene(rng, n=50)
    f2 = f2 + rng.normal(scale=0.01, size=f2.shape)
    f2 /= np.linalg.norm(f2, axis=1, keepdims=True)
    E = pose.essential()
    n1, n2 = f2 @ E.T, f1 @ E
    angle_1 = np.arcsin(np.abs(np.sum(f1 * n1, axis=1)) / np.linalg.norm(n1, axis=1))
    angle_2 = np.arcsin(np.abs(np.sum(f2 * n2, axis=1)) / np.linalg.norm(n2, axis=1))
    assert np.max(np.abs(angle_1 - angle_2) / np.maximum(angle_1, angle_2)) > 0.1
    expected = np.maximum(angle_1, angle_2)
    np.testing.assert_allclose(epipolar_errors(E, f1, f2), expected, rtol=1e-9)


def test_a_planar_motion_moves_an_offset_viewpoint_by_the_turn_too():
    """p_1 = R p_2 + t between viewpoint frames (the robot frames shifted by v): a point at
    p_r2 in robot frame 2 is at Rz p_r2 + (dx, dy, 0) in robot frame 1."""
    delta, v = np.array([0.4, -0.2, 0.7]), np.array([0.1, 0.05, 0.85])
    pose = RelativePose.from_planar_motion(delta, v)
    c, s = np.cos(delta[2]), np.sin(delta[2])
    Rz = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    p_r2 = np.array([[2.0, 1.0, 0.3], [-1.0, 3.0, 1.2]])
    p_r1 = p_r2 @ Rz.T + np.array([delta[0], delta[1], 0.0])
    np.testing.assert_allclose(p_r1 - v, (p_r2 - v) @ pose.R.T + pose.t, atol=1e-12)


def test_kabsch_returns_a_rotation_for_bearings_in_one_plane():
    """Kabsch with the determinant's sign corrected: horizontal bearings (the orthogonal
    matrix is free to reflect z) give Rz(0.3) itself, mirrored ones a proper rotation."""
    from omnislam.frontend.verification import rotation_from_bearings

    az = np.linspace(-3.0, 3.0, 12)
    f1 = np.column_stack([np.cos(az), np.sin(az), np.zeros(12)])
    R = RelativePose.from_planar_motion(np.array([0.0, 0.0, 0.3]), np.zeros(3)).R
    got = rotation_from_bearings(f1, f1 @ R)  # f2 = R^T f1
    np.testing.assert_allclose(got, R, atol=EXACT_RAD)
    # bearings mirrored in z: the best orthogonal matrix is the mirror, the answer a rotation
    rng = np.random.default_rng(11)
    g1 = rng.normal(size=(20, 3))
    g1 /= np.linalg.norm(g1, axis=1, keepdims=True)
    got = rotation_from_bearings(g1, g1 * np.array([1.0, 1.0, -1.0]))
    np.testing.assert_allclose(got @ got.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(got) > 0


def test_the_rotation_model_allows_the_parallax_of_near_points():
    """A baseline of 1.5 cm (< min_baseline_m): points 1-6 m away move by up to
    baseline / depth = 0.015 rad, which the threshold 0.004 + baseline / NEAR_DEPTH_M allows."""
    rng = np.random.default_rng(9)
    _, f1, f2 = _scene(rng, n=100, delta=(0.015, 0.0, 0.3), viewpoint=(0.0, 0.0, 0.0))
    prior = RelativePose.from_planar_motion(np.array([0.015, 0.0, 0.3]), np.zeros(3))
    result = verify_matches(f1, f2, prior, VerificationConfig(), np.random.default_rng(0))
    assert result.kind is ModelKind.ROTATION and result.n_inliers == 100
    # a baseline of exactly min_baseline_m is epipolar geometry's
    _, f1, f2 = _scene(rng, n=100, delta=(0.02, 0.0, 0.1), viewpoint=(0.0, 0.0, 0.0))
    prior = RelativePose.from_planar_motion(np.array([0.02, 0.0, 0.1]), np.zeros(3))
    assert prior.baseline_m == VerificationConfig().min_baseline_m
    result = verify_matches(f1, f2, prior, VerificationConfig(), np.random.default_rng(0))
    assert result.kind is ModelKind.ESSENTIAL


def test_the_rotation_guard_compares_turns_modulo_a_full_turn():
    """Odometry turned pi - 0.005, the images -pi + 0.005: 0.01 rad apart, not 2 pi - 0.01."""
    rng = np.random.default_rng(10)
    _, f1, f2 = _scene(rng, n=150, delta=(0.3, 0.1, -np.pi + 0.005))
    odometry = np.array([0.3, 0.1, np.pi - 0.005])
    prior = RelativePose.from_planar_motion(odometry, np.array([0.0, 0.0, 0.85]))
    result = verify_matches(f1, f2, prior, VerificationConfig(), np.random.default_rng(0))
    assert result.n_inliers == 150


def _bearings(points_1, pose):
    """Unit bearings of points (viewpoint frame 1) from both viewpoints."""
    points_2 = (points_1 - pose.t) @ pose.R
    return (points_1 / np.linalg.norm(points_1, axis=1, keepdims=True),
            points_2 / np.linalg.norm(points_2, axis=1, keepdims=True))


def test_a_floor_tile_one_period_on_fits_the_epipolar_plane_but_meets_below_the_floor():
    """Driving 1.5 m along a floor tiled with a 1.5 m period: each tile corner seen from the
    second viewpoint at the place its predecessor was seen from the first fits E exactly
    (the mismatch moves along the epipolar plane), and only the floor's height refuses it."""
    height, period = 0.85, 1.5
    pose = RelativePose.from_planar_motion(np.array([period, 0.0, 0.05]), np.zeros(3))
    rng = np.random.default_rng(11)
    floor = np.column_stack([rng.uniform(-3, 3, 200), rng.uniform(-3, 3, 200),
                             np.full(200, -height)])
    floor = floor[np.hypot(floor[:, 0], floor[:, 1]) > 0.5]
    f1, f2 = _bearings(floor, pose)
    _, aliased = _bearings(floor + np.array([period, 0.0, 0.0]), pose)
    slack = 3 * VerificationConfig().threshold_rad
    assert np.max(epipolar_errors(pose.essential(), f1, aliased)) < 1e-6
    assert not beyond_the_floor(f1, f2, pose.R, pose.t, height, slack).any()
    assert beyond_the_floor(f1, aliased, pose.R, pose.t, height, slack).all()
    # true floor points survive an odometry 5 % long and bearing noise of the threshold
    noisy = f2 + rng.normal(scale=VerificationConfig().threshold_rad / 2, size=f2.shape)
    noisy /= np.linalg.norm(noisy, axis=1, keepdims=True)
    assert not beyond_the_floor(f1, noisy, pose.R, 1.05 * pose.t, height, slack).any()
    # points above the floor (walls near and far, down to the floor's edge, and the ceiling)
    # are never refused, nor is anything without a floor below the viewpoint
    walls = np.column_stack([rng.uniform(-30, 30, 300), rng.choice([-1.25, 1.25], 300),
                             rng.uniform(-height + 0.01, 2.0, 300)])
    g1, g2 = _bearings(walls, pose)
    assert not beyond_the_floor(g1, g2, pose.R, pose.t, height, slack).any()
    assert not beyond_the_floor(f1, aliased, pose.R, pose.t, 0.0, slack).any()
