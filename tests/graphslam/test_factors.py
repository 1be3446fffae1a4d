"""GTSAM factor errors cross-checked against omnislam's core measurement models."""

from __future__ import annotations

import numpy as np
import pytest

from omnislam.core.measurement import (
    BearingElevation3D,
    RangeBearing2D,
    unit_vectors_from_azimuth_elevation,
)
from omnislam.core.motion import OdometryMotionModel
from omnislam.graphslam import factors as fx
from omnislam.graphslam.config import RobustKernel

gtsam = pytest.importorskip("gtsam")

#: factor errors vs core model residuals for small perturbations (first order)
SMALL = 1e-4
FIRST_ORDER_RTOL = 1e-3


def _values(*pairs):
    values = gtsam.Values()
    for key, value in pairs:
        values.insert(key, value)
    return values


def test_bearing_range_2d_error_matches_core_residual(rng):
    model = RangeBearing2D()
    wTr = np.array([1.0, -2.0, 0.7])
    landmark = np.array([4.0, 1.5])
    z_true = model.predict(wTr, landmark)[0]
    z = z_true + np.array([0.03, -0.02])
    factor = fx.bearing_range_2d(0, 7, z[1], z[0], gtsam.noiseModel.Unit.Create(2))
    values = _values((fx.pose_key(0), fx.pose2(wTr)), (fx.landmark_key(7), gtsam.Point2(landmark)))
    error = factor.unwhitenedError(values)  # GTSAM orders (bearing, range), predicted - measured
    np.testing.assert_allclose(error, -model.residual(z, z_true)[::-1], atol=1e-12)


def test_bearing_3d_with_viewpoint_pose_matches_bearing_elevation(rng):
    h = 0.8
    model = BearingElevation3D(h)
    wTr = np.array([2.0, 1.0, -0.4])
    landmark = np.array([5.0, 3.0, 2.2])
    az, el = model.predict(wTr, landmark)[0]
    values = _values(
        (fx.pose_key(0), fx.pose3_planar(wTr, h)), (fx.landmark_key(1), gtsam.Point3(landmark))
    )
    noise = gtsam.noiseModel.Unit.Create(2)
    exact = fx.bearing_3d(0, 1, unit_vectors_from_azimuth_elevation(az, el), noise)
    assert np.abs(exact.unwhitenedError(values)).max() < 1e-12
    # a small azimuth error d shows as an angle d cos(elevation); elevation error as itself
    for d_az, d_el in ((SMALL, 0.0), (0.0, SMALL)):
        ray = unit_vectors_from_azimuth_elevation(az + d_az, el + d_el)
        error = fx.bearing_3d(0, 1, ray, noise).unwhitenedError(values)
        expected = np.hypot(d_az * np.cos(el), d_el)
        np.testing.assert_allclose(np.linalg.norm(error), expected, rtol=FIRST_ORDER_RTOL)


def test_pose3_odometry_factor_equals_pose2_factor_on_planar_poses(rng):
    motion = OdometryMotionModel()
    delta = np.array([0.5, 0.05, 0.2])
    cov = motion.covariance(delta)
    wTa = np.array([1.0, 2.0, 0.3])
    wTb = np.array([1.52, 2.2, 0.48])  # close to wTa (+) delta, not equal
    f2 = fx.between_pose2(0, 1, delta, cov)
    f3 = fx.between_pose3(0, 1, delta, cov, 1e-3, 1e-3)
    v2 = _values((fx.pose_key(0), fx.pose2(wTa)), (fx.pose_key(1), fx.pose2(wTb)))
    v3 = _values(
        (fx.pose_key(0), fx.pose3_planar(wTa, 0.8)), (fx.pose_key(1), fx.pose3_planar(wTb, 0.8))
    )
    np.testing.assert_allclose(f3.error(v3), f2.error(v2), rtol=0.02)
    e3 = f3.unwhitenedError(v3)
    np.testing.assert_allclose(e3[fx.POSE3_OFF_PLANE_INDICES], 0.0, atol=1e-12)


def test_lifted_covariance_keeps_planar_block_and_is_positive_definite():
    cov = OdometryMotionModel().covariance(np.array([0.4, 0.0, 0.1]))
    cov6 = fx.lift_planar_covariance(cov, 1e-3, 2e-3)
    np.testing.assert_array_equal(
        cov6[np.ix_(fx.POSE3_PLANAR_INDICES, fx.POSE3_PLANAR_INDICES)], cov
    )
    np.testing.assert_allclose(np.diag(cov6)[[0, 1, 5]], [4e-6, 4e-6, 1e-6])
    assert np.all(np.linalg.eigvalsh(cov6) > 0)


def test_planar_prior_ignores_x_y_yaw_and_holds_z_roll_pitch():
    mean = fx.pose3_planar(np.array([1.0, 2.0, 0.5]), 0.8)
    prior = gtsam.PriorFactorPose3(fx.pose_key(0), mean, fx.planar_prior_noise(0.01, 0.02))
    moved = fx.pose3_planar(np.array([7.0, -3.0, 2.5]), 0.8)
    assert prior.error(_values((fx.pose_key(0), moved))) < 1e-12
    lifted = fx.pose3_planar(np.array([1.0, 2.0, 0.5]), 0.81)
    np.testing.assert_allclose(prior.error(_values((fx.pose_key(0), lifted))), 0.5, rtol=1e-6)


#: M-estimator weights w(|e|) of a whitened residual e with threshold k (Zhang's tutorial):
#: Huber 1 inside k and k / |e| outside, Cauchy 1 / (1 + (|e| / k)^2), none 1
KERNEL_WEIGHTS = {
    RobustKernel.NONE: lambda e, k: 1.0,
    RobustKernel.HUBER: lambda e, k: 1.0 if e <= k else k / e,
    RobustKernel.CAUCHY: lambda e, k: 1.0 / (1.0 + (e / k) ** 2),
}


@pytest.mark.parametrize("kernel", [k for k in RobustKernel if k is not RobustKernel.AUTO])
def test_robust_models_downweight_only_with_a_kernel(kernel):
    threshold = 1.345 if kernel is RobustKernel.HUBER else 2.3849
    models = fx.NoiseModels(kernel, threshold)
    model = models.diagonal(0.1, 0.2)
    assert models.diagonal(0.1, 0.2) is model  # cached
    base = model if kernel is RobustKernel.NONE else model.noise()
    np.testing.assert_allclose(base.sigmas(), [0.1, 0.2])
    if kernel is RobustKernel.NONE:
        assert isinstance(model, gtsam.noiseModel.Diagonal)
    for whitened in ([0.3, 0.4], [10.0, 0.0], [-3.0, 4.0]):
        e = float(np.linalg.norm(whitened))
        expected = KERNEL_WEIGHTS[kernel](e, threshold)
        weight = 1.0 if kernel is RobustKernel.NONE else model.weight(np.array(whitened))
        assert weight == pytest.approx(expected, rel=1e-12), whitened


def test_odometry_conditioning_floors_translation_given_rotation():
    floor = 1e-3
    # lateral motion nearly determined by the heading change (a creeping car)
    cov = np.array([[1e-6, 0.0, 0.0], [0.0, 2e-8, 1e-8], [0.0, 1e-8, 1e-8]])
    out = fx.condition_odometry_covariance(cov, floor)
    schur = out[:2, :2] - np.outer(out[:2, 2], out[2, :2]) / out[2, 2]
    np.testing.assert_allclose(np.linalg.eigvalsh(schur)[0], floor**2, rtol=1e-9)
    np.testing.assert_array_equal(out[:, 2], cov[:, 2])  # rotation untouched
    # a covariance that already respects the floor is returned unchanged
    fine = np.diag([1e-4, 4e-6, 4e-6])
    assert fx.condition_odometry_covariance(fine, floor) is fine


def test_between_covariance_matches_the_sampled_factor_error(rng):
    """A delta drawn from the motion model, seen through the factor's error Log(z^-1 x): its
    covariance is ``between_covariance``, not the delta's own (the rotation by dtheta)."""
    motion = OdometryMotionModel()
    delta = np.array([0.3, 0.05, 0.8])  # a large turn, as between two images
    cov = motion.covariance(delta)
    draws = motion.sample_delta(delta, rng, size=40_000)
    z = fx.pose2(delta)
    errors = np.array([z.localCoordinates(fx.pose2(d)) for d in draws])
    sample_cov = np.cov(errors.T)
    expected = fx.between_covariance(delta, cov)
    assert np.linalg.norm(sample_cov - expected) < 0.03 * np.linalg.norm(expected)
    assert np.linalg.norm(sample_cov - cov) > 0.3 * np.linalg.norm(cov)  # the raw one is off
